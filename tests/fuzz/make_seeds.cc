// fuzz_make_seeds OUT_DIR: small valid inputs for the binary-format fuzz targets, written with
// the repo's own writers (so the seeds follow the formats as they change): OUT_DIR/<target>/.
//   occupancy_ot    ColorOcTree .ot of a few rays (empty map too) and a plain OcTree .ot
//   cloud_pcd       binary PCDs of a filtered cloud, a few points, no points
//   bow_vocabulary  vocabularies trained on random descriptors (a few shapes)
//   feature_codec   keyframe features: ORB-like, SIFT-like (float), without descriptors, none
//   map_point_observations  stored map point observations: none, one, several (extremes)
//   image_decode, ingest_request, rpc_requests: make_wire_seeds.cc
#include <octomap/OcTree.h>

#include <Eigen/Geometry>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <opencv2/core.hpp>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include "core/mapping/occupancy_map.h"
#include "core/mapping/point_cloud_map.h"
#include "core/slam/bow_vocabulary.h"
#include "core/slam/feature_codec.h"
#include "storage/sqlite/map_point_codec.h"
#include "tests/fuzz/make_wire_seeds.h"

namespace semmap {
namespace {

namespace fs = std::filesystem;

bool Write(const fs::path& dir, const std::string& name, const std::string& bytes) {
  return fuzz::WriteSeedFile(dir, name, bytes);
}

template <typename T>
bool WriteOr(const fs::path& dir, const std::string& name, const StatusOr<T>& bytes) {
  if (!bytes.ok()) {
    std::fprintf(stderr, "fuzz_make_seeds: %s: %s\n", name.c_str(),
                 bytes.status().ToString().c_str());
    return false;
  }
  return Write(dir, name, *bytes);
}

KeyframeCloud SmallCloud(int points, uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> xy(-0.5F, 0.5F), z(0.8F, 1.6F);
  KeyframeCloud cloud;
  for (int i = 0; i < points; ++i) {
    cloud.points.emplace_back(xy(rng), xy(rng), z(rng));
    cloud.colours.push_back(
        {static_cast<uint8_t>(rng()), static_cast<uint8_t>(rng()), static_cast<uint8_t>(rng())});
  }
  return cloud;
}

bool OccupancySeeds(const fs::path& dir) {
  bool ok = true;
  OccupancyMapOptions options;
  options.resolution_m = 0.25;
  options.max_range_m = 2.0;
  StatusOr<OccupancyMap> empty = OccupancyMap::Create(options);
  ok &= empty.ok() && WriteOr(dir, "empty.ot", empty->SerializeOt());
  const KeyframeCloud cloud = SmallCloud(3, 1);
  StatusOr<OccupancyMap> map =
      OccupancyMap::Build({{&cloud, Eigen::Isometry3d::Identity()}}, options);
  ok &= map.ok() && WriteOr(dir, "three_rays.ot", map->SerializeOt());
  options.resolution_m = 0.5;
  const KeyframeCloud more = SmallCloud(8, 2);
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.translation() = Eigen::Vector3d(0.3, -0.2, 0.1);
  map = OccupancyMap::Build({{&more, T}, {&cloud, Eigen::Isometry3d::Identity()}}, options);
  ok &= map.ok() && WriteOr(dir, "two_keyframes.ot", map->SerializeOt());
  // A plain OcTree (what other OctoMap tools write): loads uncoloured.
  octomap::OcTree tree(0.5);
  tree.updateNode(octomap::point3d(0.2F, 0.3F, 1.0F), true);
  tree.updateNode(octomap::point3d(-0.6F, 0.1F, 0.4F), false);
  std::ostringstream ot;
  tree.write(ot);
  ok &= Write(dir, "octree.ot", ot.str());
  return ok;
}

bool CloudSeeds(const fs::path& dir) {
  bool ok = true;
  ok &= WriteOr(dir, "empty.pcd", PointCloudMap().ToPcd(true));
  std::vector<CloudPoint> points = {{0.F, 0.F, 1.F, 255, 0, 0}, {-0.5F, 0.25F, 2.F, 0, 128, 255}};
  ok &= WriteOr(dir, "two_points.pcd",
                PointCloudMap::FromPoints(points, PointCloudMapOptions{}).ToPcd(true));
  const KeyframeCloud cloud = SmallCloud(40, 3);
  PointCloudMapOptions options;
  options.leaf_size_m = 0.1;
  StatusOr<PointCloudMap> map =
      PointCloudMap::Build({{&cloud, Eigen::Isometry3d::Identity()}}, options);
  ok &= map.ok() && WriteOr(dir, "filtered.pcd", map->ToPcd(true));
  return ok;
}

bool VocabularySeeds(const fs::path& dir) {
  bool ok = true;
  struct Shape {
    int branching, levels, bytes, images, rows;
  };
  // Up to the shape of models/orb_vocab.bin (k 10, 32 bytes) at a depth that keeps it small.
  const Shape shapes[] = {
      {2, 1, 8, 2, 4}, {3, 2, 32, 3, 12}, {4, 3, 16, 4, 20}, {10, 2, 32, 3, 120}};
  std::mt19937 rng(7);
  for (const Shape& s : shapes) {
    std::vector<cv::Mat> sets;
    for (int i = 0; i < s.images; ++i) {
      cv::Mat set(s.rows, s.bytes, CV_8UC1);
      for (int r = 0; r < set.rows; ++r) {
        for (int c = 0; c < set.cols; ++c) set.at<uint8_t>(r, c) = static_cast<uint8_t>(rng());
      }
      sets.push_back(set);
    }
    BowTrainingOptions options;
    options.branching = s.branching;
    options.levels = s.levels;
    StatusOr<BowVocabulary> v = BowVocabulary::Train(sets, options);
    if (!v.ok()) {
      std::fprintf(stderr, "fuzz_make_seeds: vocabulary: %s\n", v.status().ToString().c_str());
      ok = false;
      continue;
    }
    ok &= Write(dir,
                "k" + std::to_string(s.branching) + "_l" + std::to_string(s.levels) + "_b" +
                    std::to_string(s.bytes) + ".voc",
                v->Serialize());
  }
  return ok;
}

FrameFeatures Features(int count, int cols, int type, uint32_t seed) {
  std::mt19937 rng(seed);
  FrameFeatures f;
  for (int i = 0; i < count; ++i) {
    f.keypoints.emplace_back(static_cast<float>(rng() % 640), static_cast<float>(rng() % 480), 31.F,
                             static_cast<float>(rng() % 360), 0.01F * static_cast<float>(i), i % 3);
    const bool depth = i % 2 == 0;
    f.has_depth.push_back(depth);
    f.points_camera.push_back(depth ? Eigen::Vector3d(0.1 * i, -0.05 * i, 1.0 + 0.1 * i)
                                    : Eigen::Vector3d::Zero());
  }
  if (cols > 0 && count > 0) {
    f.descriptors.create(count, cols, type);
    cv::randu(f.descriptors, 0, 255);
  }
  return f;
}

bool FeatureSeeds(const fs::path& dir) {
  bool ok = true;
  ok &= Write(dir, "none.bin", EncodeFeatures(Features(0, 0, CV_8U, 1)));
  ok &= Write(dir, "orb.bin", EncodeFeatures(Features(4, 32, CV_8U, 2)));
  ok &= Write(dir, "float.bin", EncodeFeatures(Features(3, 8, CV_32F, 3)));
  ok &= Write(dir, "no_descriptors.bin", EncodeFeatures(Features(2, 0, CV_8U, 4)));
  return ok;
}

bool MapPointObservationSeeds(const fs::path& dir) {
  using Observations = std::vector<MapPointObservationRecord>;
  bool ok = WriteOr(dir, "none.bin", sqlite::EncodeMapPointObservations(Observations{}));
  ok &= WriteOr(dir, "one.bin", sqlite::EncodeMapPointObservations(Observations{{1, 0, 17}}));
  const Observations several = {
      {1, 4, 0}, {2, 9, 311}, {3, 1'000'000, 2'147'483'647}, {9'000'000'000, 0, 5}};
  ok &= WriteOr(dir, "several.bin", sqlite::EncodeMapPointObservations(several));
  return ok;
}

}  // namespace
}  // namespace semmap

int main(int argc, char** argv) {
  if (argc != 2) {
    std::fprintf(stderr, "usage: fuzz_make_seeds OUT_DIR\n");
    return 2;
  }
  const std::filesystem::path out = argv[1];
  bool ok = semmap::OccupancySeeds(out / "occupancy_ot");
  ok &= semmap::CloudSeeds(out / "cloud_pcd");
  ok &= semmap::VocabularySeeds(out / "bow_vocabulary");
  ok &= semmap::FeatureSeeds(out / "feature_codec");
  ok &= semmap::MapPointObservationSeeds(out / "map_point_observations");
  ok &= semmap::fuzz::ImageSeeds(out / "image_decode");
  ok &= semmap::fuzz::IngestSeeds(out / "ingest_request");
  ok &= semmap::fuzz::RequestSeeds(out / "rpc_requests");
  return ok ? 0 : 1;
}
