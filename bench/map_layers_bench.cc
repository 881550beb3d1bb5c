// The map layers (core/mapping) on synthetic room keyframes as semmapd keeps them (every 4th
// pixel, 2 cm keyframe voxels, 5 cm tree, 4 m range, 2 cm cloud leaves): 30 keyframes of the
// circle trajectory. Occupancy insertion into a fresh tree per iteration:
//   Insert/semmap           OccupancyMap::Insert (rays, one-descent batch update, colours)
//   Insert/octomap          ColorOcTree::insertPointCloud on the same points (no colours)
//   Rays+update/semmap      ComputeScanUpdates + ApplyCellUpdates (the occupancy part alone)
//   Rays+update/octomap     computeDiscreteUpdate + updateNode per voxel, as OctoMap inserts
//   Build                   OccupancyMap::Build of all 30 (the rebuild after a loop closure)
// ms_per_keyframe is the figure to compare; the ratio semmap / octomap is printed at the end.
// The coloured cloud layer, for a map of N keyframes (the 30, repeated 5 m apart beyond that):
//   Cloud/filter_all/N      what a persist cost before the incremental cloud: PCL's voxel grid
//                           over every keyframe's points (PointCloudMap::Build)
//   Cloud/snapshot/N        what it costs now: IncrementalCloud::Snapshot of the leaf sums
//   Cloud/move_keyframe/N   a correction moving one keyframe: Remove + Add
// Run: build/release/bench/map_layers_bench
#include <benchmark/benchmark.h>
#include <octomap/ColorOcTree.h>

#include <Eigen/Geometry>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <map>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "core/mapping/incremental_cloud.h"
#include "core/mapping/internal/octree_batch_update.h"
#include "core/mapping/occupancy_map.h"
#include "core/mapping/point_cloud_map.h"
#include "tests/testing/synth/renderer.h"
#include "tests/testing/synth/room_circle.h"

namespace semmap {
namespace {

struct Keyframe {
  KeyframeCloud cloud;
  Eigen::Isometry3d T_world_camera;
  octomap::Pointcloud world;  // the cloud's points in the world, as OctoMap takes them
  octomap::point3d origin;
};

OccupancyMapOptions Options() {
  OccupancyMapOptions options;
  options.keyframe_voxel_m = 0.02;  // semmapd's --map-keyframe-voxel default
  return options;
}

const std::vector<Keyframe>& Keyframes() {
  static const std::vector<Keyframe>* keyframes = [] {
    StatusOr<synth::RoomCircle> circle = synth::RenderRoomCircle(120, 4);
    if (!circle.ok()) std::abort();
    auto* out = new std::vector<Keyframe>;
    for (const synth::RoomView& view : circle->views) {
      const Eigen::Isometry3d& T = view.T_world_camera;
      StatusOr<KeyframeCloud> cloud = MakeKeyframeCloud({view.frame.depth, synth::kDepthScale},
                                                        view.frame.bgr, circle->camera, Options());
      if (!cloud.ok()) std::abort();
      Keyframe k{std::move(cloud).value(), T, {}, {}};
      const Eigen::Isometry3f Tf = T.cast<float>();
      for (const Eigen::Vector3f& p : k.cloud.points) {
        const Eigen::Vector3f w = Tf * p;
        k.world.push_back(w.x(), w.y(), w.z());
      }
      k.origin = octomap::point3d(static_cast<float>(T.translation().x()),
                                  static_cast<float>(T.translation().y()),
                                  static_cast<float>(T.translation().z()));
      out->push_back(std::move(k));
    }
    return out;
  }();
  return *keyframes;
}

std::map<std::string, double>& MsPerKeyframe() {
  static std::map<std::string, double> figures;
  return figures;
}

void Report(benchmark::State& state, const std::string& name, double seconds) {
  const double keyframes = static_cast<double>(Keyframes().size());
  const double ms = 1e3 * seconds / (static_cast<double>(state.iterations()) * keyframes);
  state.counters["ms_per_keyframe"] = ms;
  state.counters["points_per_keyframe"] = static_cast<double>(Keyframes().front().cloud.size());
  MsPerKeyframe()[name] = ms;
}

// Times `insert_all` (a fresh tree each iteration, its construction untimed).
template <typename Tree, typename MakeTree, typename InsertAll>
void TimeInsertion(benchmark::State& state, const std::string& name, MakeTree make_tree,
                   InsertAll insert_all) {
  Keyframes();  // rendered once, before any timing
  double seconds = 0;
  for (auto _ : state) {
    Tree tree = make_tree();
    const auto t0 = std::chrono::steady_clock::now();
    insert_all(tree);
    seconds += std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    benchmark::DoNotOptimize(tree);
  }
  Report(state, name, seconds);
}

void BM_InsertSemmap(benchmark::State& state) {
  TimeInsertion<OccupancyMap>(
      state, "Insert/semmap", [] { return std::move(OccupancyMap::Create(Options())).value(); },
      [](OccupancyMap& map) {
        for (const Keyframe& k : Keyframes()) {
          if (!map.Insert(k.cloud, k.T_world_camera).ok()) std::abort();
        }
      });
}
BENCHMARK(BM_InsertSemmap)->Name("Insert/semmap")->Unit(benchmark::kMillisecond)->UseRealTime();

void BM_InsertOctomap(benchmark::State& state) {
  const OccupancyMapOptions options = Options();
  TimeInsertion<std::unique_ptr<octomap::ColorOcTree>>(
      state, "Insert/octomap",
      [&] { return std::make_unique<octomap::ColorOcTree>(options.resolution_m); },
      [&](std::unique_ptr<octomap::ColorOcTree>& tree) {
        for (const Keyframe& k : Keyframes()) {
          tree->insertPointCloud(k.world, k.origin, options.max_range_m, /*lazy_eval=*/false,
                                 /*discretize=*/true);
        }
      });
}
BENCHMARK(BM_InsertOctomap)->Name("Insert/octomap")->Unit(benchmark::kMillisecond)->UseRealTime();

// The discretized scan OctoMap ray-casts: the centres of the distinct end voxels.
octomap::Pointcloud EndVoxelCentres(const octomap::ColorOcTree& tree, const Keyframe& k) {
  octomap::KeySet ends;
  for (const octomap::point3d& p : k.world) {
    octomap::OcTreeKey key;
    if (tree.coordToKeyChecked(p, key)) ends.insert(key);
  }
  octomap::Pointcloud centres;
  for (const octomap::OcTreeKey& key : ends) centres.push_back(tree.keyToCoord(key));
  return centres;
}

void BM_RaysAndUpdateSemmap(benchmark::State& state) {
  const OccupancyMapOptions options = Options();
  TimeInsertion<std::unique_ptr<octomap::ColorOcTree>>(
      state, "Rays+update/semmap",
      [&] { return std::make_unique<octomap::ColorOcTree>(options.resolution_m); },
      [&](std::unique_ptr<octomap::ColorOcTree>& tree) {
        for (const Keyframe& k : Keyframes()) {
          internal::ApplyCellUpdates(
              *tree, internal::ComputeScanUpdates(*tree, EndVoxelCentres(*tree, k), k.origin,
                                                  options.max_range_m));
        }
      });
}
BENCHMARK(BM_RaysAndUpdateSemmap)
    ->Name("Rays+update/semmap")
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();

void BM_RaysAndUpdateOctomap(benchmark::State& state) {
  const OccupancyMapOptions options = Options();
  TimeInsertion<std::unique_ptr<octomap::ColorOcTree>>(
      state, "Rays+update/octomap",
      [&] { return std::make_unique<octomap::ColorOcTree>(options.resolution_m); },
      [&](std::unique_ptr<octomap::ColorOcTree>& tree) {
        for (const Keyframe& k : Keyframes()) {
          octomap::KeySet free_cells, occupied_cells;
          tree->computeUpdate(EndVoxelCentres(*tree, k), k.origin, free_cells, occupied_cells,
                              options.max_range_m);
          for (const octomap::OcTreeKey& key : free_cells) tree->updateNode(key, false, false);
          for (const octomap::OcTreeKey& key : occupied_cells) tree->updateNode(key, true, false);
        }
      });
}
BENCHMARK(BM_RaysAndUpdateOctomap)
    ->Name("Rays+update/octomap")
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();

void BM_Build(benchmark::State& state) {
  std::vector<std::pair<const KeyframeCloud*, Eigen::Isometry3d>> all;  // renders first
  for (const Keyframe& k : Keyframes()) all.emplace_back(&k.cloud, k.T_world_camera);
  double seconds = 0;
  for (auto _ : state) {
    const auto t0 = std::chrono::steady_clock::now();
    StatusOr<OccupancyMap> map = OccupancyMap::Build(all, Options());
    seconds += std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    if (!map.ok()) std::abort();
    benchmark::DoNotOptimize(map);
  }
  Report(state, "Build", seconds);
}
BENCHMARK(BM_Build)->Name("Build")->Unit(benchmark::kMillisecond)->UseRealTime();

// N keyframes: the room's, repeated along x 5 m apart (a bigger home) until there are N.
std::vector<std::pair<const KeyframeCloud*, Eigen::Isometry3d>> MapOf(size_t n) {
  std::vector<std::pair<const KeyframeCloud*, Eigen::Isometry3d>> out;
  for (size_t i = 0; i < n; ++i) {
    const Keyframe& k = Keyframes()[i % Keyframes().size()];
    Eigen::Isometry3d T = k.T_world_camera;
    const size_t copy = i / Keyframes().size();  // which repetition of the room
    T.translation().x() += 5.0 * static_cast<double>(copy);
    out.emplace_back(&k.cloud, T);
  }
  return out;
}

void BM_CloudFilterAll(benchmark::State& state) {
  const auto map = MapOf(static_cast<size_t>(state.range(0)));
  for (auto _ : state) {
    StatusOr<PointCloudMap> cloud = PointCloudMap::Build(map, {});
    if (!cloud.ok()) std::abort();
    benchmark::DoNotOptimize(cloud);
  }
}
BENCHMARK(BM_CloudFilterAll)
    ->Name("Cloud/filter_all")
    ->Arg(30)
    ->Arg(300)
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();

IncrementalCloud IncrementalOf(size_t n) {
  StatusOr<IncrementalCloud> cloud = IncrementalCloud::Create({});
  if (!cloud.ok()) std::abort();
  for (const auto& [kf, T] : MapOf(n)) {
    if (!cloud->Add(*kf, T).ok()) std::abort();
  }
  return std::move(cloud).value();
}

void BM_CloudSnapshot(benchmark::State& state) {
  const IncrementalCloud cloud = IncrementalOf(static_cast<size_t>(state.range(0)));
  for (auto _ : state) benchmark::DoNotOptimize(cloud.Snapshot());
  state.counters["leaves"] = static_cast<double>(cloud.size());
  state.counters["MB"] = static_cast<double>(cloud.MemoryBytes()) / 1e6;
}
BENCHMARK(BM_CloudSnapshot)
    ->Name("Cloud/snapshot")
    ->Arg(30)
    ->Arg(300)
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();

void BM_CloudMoveKeyframe(benchmark::State& state) {
  IncrementalCloud cloud = IncrementalOf(static_cast<size_t>(state.range(0)));
  const Keyframe& k = Keyframes()[3];
  Eigen::Isometry3d T = k.T_world_camera, moved = T;
  moved.translation().x() += 0.01;
  for (auto _ : state) {
    if (!cloud.Remove(k.cloud, T).ok() || !cloud.Add(k.cloud, moved).ok()) std::abort();
    std::swap(T, moved);
  }
}
BENCHMARK(BM_CloudMoveKeyframe)
    ->Name("Cloud/move_keyframe")
    ->Arg(30)
    ->Arg(300)
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();

}  // namespace
}  // namespace semmap

int main(int argc, char** argv) {
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  const auto& ms = semmap::MsPerKeyframe();
  for (const char* part : {"Insert", "Rays+update"}) {
    const auto semmap = ms.find(std::string(part) + "/semmap");
    const auto octomap = ms.find(std::string(part) + "/octomap");
    if (semmap == ms.end() || octomap == ms.end()) continue;
    std::printf("%s: semmap %.2f ms / keyframe, octomap %.2f ms / keyframe, ratio %.2f\n", part,
                semmap->second, octomap->second, semmap->second / octomap->second);
  }
  return 0;
}
