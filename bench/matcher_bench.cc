// Descriptor matching (core/odometry/feature_matcher) on ORB descriptors of synthetic 640x480
// frames of the default room: MatchDescriptors (ratio test + cross check, the matcher of loop
// verification and relocalisation) for query x train rows of 1000x1000 and 500x1000, and
// MatchGuided with 12 px windows around predictions 3 px off the true projections. CPU is the
// process's (all threads); Time is wall-clock.
#include <benchmark/benchmark.h>

#include <cstdlib>
#include <optional>
#include <vector>

#include "core/odometry/feature_extractor.h"
#include "core/odometry/feature_matcher.h"
#include "tests/testing/synth/default_scene.h"
#include "tests/testing/synth/renderer.h"
#include "tests/testing/synth/sequence_writer.h"
#include "tests/testing/synth/trajectory.h"

namespace semmap {
namespace {

struct Views {
  std::vector<FrameFeatures> features;  // frames 10, 13, 40, 43, 70, 73 of a 120-frame circle
};

// Rendered and extracted once per process (not timed).
const Views& GetViews() {
  static const Views* const views = [] {
    auto* v = new Views;
    const CameraCalibration camera = synth::DefaultSyntheticCamera();
    StatusOr<synth::Scene> scene = synth::MakeDefaultRoomScene(1);
    if (!scene.ok()) std::abort();
    StatusOr<synth::Renderer> renderer = synth::Renderer::Create(*scene, camera);
    if (!renderer.ok()) std::abort();
    synth::TrajectoryOptions options;
    options.frames = 120;
    StatusOr<std::vector<StampedPose>> poses = synth::CircleTrajectory(scene->room, options);
    if (!poses.ok()) std::abort();
    StatusOr<FeatureExtractor> extractor = FeatureExtractor::Create({}, camera);
    if (!extractor.ok()) std::abort();
    for (int frame : {10, 13, 40, 43, 70, 73}) {
      const synth::RenderedFrame f =
          renderer->Render((*poses)[static_cast<size_t>(frame)].T_world_camera);
      StatusOr<FrameFeatures> features = extractor->Extract(f.bgr, f.depth, synth::kDepthScale);
      if (!features.ok()) std::abort();
      v->features.push_back(std::move(features).value());
    }
    return v;
  }();
  return *views;
}

// `rows` descriptor rows from views first, first + 2, ... (a frame has up to 1000).
cv::Mat Rows(size_t first, int rows) {
  const Views& v = GetViews();
  cv::Mat out;
  for (size_t k = first; out.rows < rows && k < v.features.size(); k += 2) {
    out.push_back(v.features[k].descriptors);
  }
  if (out.rows < rows) std::abort();
  return out.rowRange(0, rows).clone();
}

void BM_MatchDescriptors(benchmark::State& state) {
  const cv::Mat query = Rows(0, static_cast<int>(state.range(0)));
  const cv::Mat train = Rows(1, static_cast<int>(state.range(1)));
  size_t matches = 0;
  for (auto _ : state) {
    StatusOr<std::vector<cv::DMatch>> m = MatchDescriptors(query, train, {});
    if (!m.ok()) std::abort();
    matches = m->size();
    benchmark::DoNotOptimize(m);
  }
  state.counters["matches"] = static_cast<double>(matches);
}
BENCHMARK(BM_MatchDescriptors)
    ->Args({1000, 1000})
    ->Args({500, 1000})
    ->ArgNames({"query", "train"})
    ->MeasureProcessCPUTime()  // OpenCV's matcher ran on worker threads too
    ->Unit(benchmark::kMillisecond);

void BM_MatchGuided(benchmark::State& state) {
  // Frame 10 against frame 13 with predictions from a full match, offset by (3, -2) px.
  const Views& v = GetViews();
  const FrameFeatures& a = v.features[0];
  const FrameFeatures& b = v.features[1];
  StatusOr<std::vector<cv::DMatch>> full = MatchDescriptors(a.descriptors, b.descriptors, {});
  if (!full.ok()) std::abort();
  std::vector<std::optional<cv::Point2f>> predicted(a.size());
  for (const cv::DMatch& m : *full) {
    predicted[static_cast<size_t>(m.queryIdx)] =
        b.keypoints[static_cast<size_t>(m.trainIdx)].pt + cv::Point2f(3, -2);
  }
  size_t matches = 0;
  for (auto _ : state) {
    StatusOr<std::vector<cv::DMatch>> m =
        MatchGuided(a.descriptors, predicted, b.descriptors, b.keypoints, {});
    if (!m.ok()) std::abort();
    matches = m->size();
    benchmark::DoNotOptimize(m);
  }
  state.counters["matches"] = static_cast<double>(matches);
  state.counters["predicted"] = static_cast<double>(full->size());
}
BENCHMARK(BM_MatchGuided)->MeasureProcessCPUTime()->Unit(benchmark::kMicrosecond);

}  // namespace
}  // namespace semmap

BENCHMARK_MAIN();
