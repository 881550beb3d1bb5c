// MapLayerBuilder and the layer exports, over a real SQLite store: keyframes of the synthetic
// room go in as images + poses (either order), the persisted blobs equal a fresh build, a
// correction rebuilds the map to match a fresh build from the corrected poses, a restarted
// builder restores from the stored keyframes, and exports read back (PCL, OctoMap); damaged
// blobs are DATA_LOSS.
#include <gtest/gtest.h>
#include <octomap/OcTree.h>
#include <pcl/io/pcd_io.h>
#include <pcl/io/ply_io.h>
#include <pcl/point_types.h>
#include <sqlite3.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <functional>
#include <memory>
#include <opencv2/imgcodecs.hpp>
#include <sstream>
#include <string>
#include <tuple>
#include <vector>

#include "core/mapping/cloud_pcd_reader.h"
#include "core/mapping/layer_frame.h"
#include "core/mapping/map_layer_builder.h"
#include "core/query/map_export.h"
#include "storage/sqlite/sqlite_map_store.h"
#include "storage/storage_writer.h"
#include "tests/testing/same_cloud.h"
#include "tests/testing/synth/default_scene.h"
#include "tests/testing/synth/renderer.h"
#include "tests/testing/synth/sequence_writer.h"
#include "tests/testing/synth/trajectory.h"
#include "tests/testing/temp_dir.h"
#include "tests/testing/test_store.h"

namespace semmap {
namespace {

struct Keyframe {
  int64_t seq = 0;
  synth::RenderedFrame frame;
  Eigen::Isometry3d T_world_camera;
};

const synth::Renderer& SharedRenderer() {
  static const synth::Renderer* const renderer = [] {
    static StatusOr<synth::Scene> scene = synth::MakeDefaultRoomScene(1);
    if (!scene.ok()) std::abort();
    StatusOr<synth::Renderer> r = synth::Renderer::Create(*scene, synth::DefaultSyntheticCamera());
    if (!r.ok()) std::abort();
    return new synth::Renderer(std::move(r).value());
  }();
  return *renderer;
}

// 12 keyframes around the synthetic room (every 10th frame of a 120-frame circle).
const std::vector<Keyframe>& Keyframes() {
  static const std::vector<Keyframe>* const keyframes = [] {
    StatusOr<synth::Scene> scene = synth::MakeDefaultRoomScene(1);
    synth::TrajectoryOptions options;
    options.frames = 120;
    StatusOr<std::vector<StampedPose>> poses = synth::CircleTrajectory(scene->room, options);
    if (!poses.ok()) std::abort();
    auto* out = new std::vector<Keyframe>;
    for (size_t i = 0; i < poses->size(); i += 10) {
      out->push_back({static_cast<int64_t>(i), SharedRenderer().Render((*poses)[i].T_world_camera),
                      (*poses)[i].T_world_camera});
    }
    return out;
  }();
  return *keyframes;
}

// A small drift that grows along the lap (what a loop closure corrects).
Eigen::Isometry3d Drifted(const Keyframe& k) {
  const double s = static_cast<double>(k.seq) / 120.0;
  Eigen::Isometry3d drift = Eigen::Isometry3d::Identity();
  drift.translation() = Eigen::Vector3d(0.15 * s, 0, -0.1 * s);
  drift.linear() = Eigen::AngleAxisd(0.05 * s, Eigen::Vector3d::UnitY()).toRotationMatrix();
  return drift * k.T_world_camera;
}

std::vector<std::pair<const KeyframeCloud*, Eigen::Isometry3d>> FreshInput(
    const std::vector<KeyframeCloud>& clouds, bool drifted) {
  std::vector<std::pair<const KeyframeCloud*, Eigen::Isometry3d>> out;
  for (size_t i = 0; i < clouds.size(); ++i) {
    const Keyframe& k = Keyframes()[i];
    out.emplace_back(&clouds[i], drifted ? Drifted(k) : k.T_world_camera);
  }
  return out;
}

std::vector<KeyframeCloud> Clouds(const MapLayerOptions& options) {
  std::vector<KeyframeCloud> out;
  for (const Keyframe& k : Keyframes()) {
    StatusOr<KeyframeCloud> cloud =
        MakeKeyframeCloud({k.frame.depth, synth::kDepthScale}, k.frame.bgr,
                          SharedRenderer().camera(), options.occupancy);
    EXPECT_TRUE(cloud.ok()) << cloud.status().ToString();
    out.push_back(std::move(cloud).value());
  }
  return out;
}

using VoxelKey = std::tuple<double, double, double, double, float>;
std::vector<VoxelKey> Keys(const OccupancyMap& map) {
  std::vector<VoxelKey> keys;
  for (const OccupancyMap::Voxel& v : map.OccupiedVoxels()) {
    keys.emplace_back(v.centre.x(), v.centre.y(), v.centre.z(), v.size, v.log_odds);
  }
  return keys;
}

std::vector<std::tuple<float, float, float, int, int, int>> PointKeys(
    const std::vector<CloudPoint>& points) {
  std::vector<std::tuple<float, float, float, int, int, int>> out;
  out.reserve(points.size());
  for (const CloudPoint& p : points) out.emplace_back(p.x, p.y, p.z, p.r, p.g, p.b);
  std::sort(out.begin(), out.end());
  return out;
}

class MapLayersTest : public ::testing::Test {
 protected:
  void SetUp() override {
    options_.persist_interval_s = 3600;  // only Flush persists: deterministic blob contents
    StatusOr<std::unique_ptr<testing::TestStore>> store =
        testing::MakeTestStore("room", "lap", SharedRenderer().camera(), synth::kDepthScale);
    ASSERT_TRUE(store.ok()) << store.status().ToString();
    store_ = std::move(store).value();
    map_ = store_->map;
    session_ = store_->session;
    read_ = store_->read.get();
    writer_ = store_->writer.get();
    db_ = store_->db_path;
  }

  std::unique_ptr<MapLayerBuilder> StartBuilder(bool restore) {
    StatusOr<std::unique_ptr<MapLayerBuilder>> builder = MapLayerBuilder::Start(
        map_.id, map_.name, options_, writer_,
        restore ? StoreRestore::ThroughReader(SqliteMapStore::Opener(store_->db_path, {}))
                : StoreRestore::None());
    EXPECT_TRUE(builder.ok()) << builder.status().ToString();
    return builder.ok() ? std::move(builder).value() : nullptr;
  }

  // Images first for even keyframes, the pose first for odd ones.
  void Feed(MapLayerBuilder& builder, bool drifted) {
    for (const Keyframe& k : Keyframes()) {
      const KeyframePose pose{session_.id, k.seq, drifted ? Drifted(k) : k.T_world_camera};
      const bool images_first = (k.seq / 10) % 2 == 0;
      if (!images_first) {
        ASSERT_TRUE(builder.SetKeyframePoses({pose}, false).ok());
      }
      ASSERT_TRUE(builder
                      .AddKeyframeImages(session_.id, k.seq, {k.frame.depth, synth::kDepthScale},
                                         k.frame.bgr, SharedRenderer().camera())
                      .ok());
      if (images_first) {
        ASSERT_TRUE(builder.SetKeyframePoses({pose}, false).ok());
      }
    }
  }

  // The keyframes as an ingest session stores them (PNG or JPEG colour, PNG depth, poses).
  void StoreKeyframes(bool drifted, const std::string& colour_format = "png") {
    WriteBatch batch;
    for (const Keyframe& k : Keyframes()) {
      TrajectoryPose pose;
      pose.seq = k.seq;
      pose.stamp_ns = 1'000'000'000 + k.seq * 33'000'000;
      pose.T_world_camera = drifted ? Drifted(k) : k.T_world_camera;
      pose.is_keyframe = true;
      batch.frames.emplace_back(session_.id, pose);
      KeyframeRecord record;
      record.session_id = session_.id;
      record.seq = k.seq;
      record.stamp_ns = pose.stamp_ns;
      record.T_world_camera = pose.T_world_camera;
      std::vector<uint8_t> png;
      cv::imencode("." + colour_format, k.frame.bgr, png);
      record.colour = {colour_format, std::string(png.begin(), png.end())};
      cv::imencode(".png", k.frame.depth, png);
      record.depth = {"png", std::string(png.begin(), png.end())};
      record.depth_scale = synth::kDepthScale;
      batch.keyframes.push_back(std::move(record));
    }
    ASSERT_TRUE(
        writer_->RunSync([&](MapStore& store) { return store.Write(batch).status(); }).ok());
  }

  OccupancyMap StoredOccupancy() {
    StatusOr<MapBlob> blob = read_->GetBlob(map_.id, kOccupancyBlobKind);
    EXPECT_TRUE(blob.ok()) << blob.status().ToString();
    StatusOr<OccupancyMap> map = OccupancyMap::DeserializeOt(blob.ok() ? blob->data : "");
    EXPECT_TRUE(map.ok()) << map.status().ToString();
    return map.ok() ? std::move(map).value() : std::move(OccupancyMap::Create({})).value();
  }

  std::vector<CloudPoint> StoredCloud() {
    StatusOr<MapBlob> blob = read_->GetBlob(map_.id, kCloudBlobKind);
    EXPECT_TRUE(blob.ok()) << blob.status().ToString();
    StatusOr<std::vector<CloudPoint>> points = ReadCloudPcd(blob.ok() ? blob->data : "");
    EXPECT_TRUE(points.ok()) << points.status().ToString();
    return points.ok() ? *points : std::vector<CloudPoint>{};
  }

  StatusOr<ExportResult> Export(const std::string& format, const std::string& session = "",
                                double voxel = 0) {
    ExportRequest request;
    request.map = map_.name;
    request.format = format;
    request.session = session;
    request.voxel_m = voxel;
    return BuildExport(*read_, request, options_);
  }

  // Changes the store under the builder, as damage on disk would.
  void ExecSql(const std::string& sql) {
    sqlite3* db = nullptr;
    ASSERT_EQ(sqlite3_open(db_.c_str(), &db), SQLITE_OK);
    EXPECT_EQ(sqlite3_exec(db, sql.c_str(), nullptr, nullptr, nullptr), SQLITE_OK)
        << sqlite3_errmsg(db);
    sqlite3_close(db);
  }
  void CorruptKeyframeDepth(int64_t seq) {
    ExecSql("UPDATE keyframes SET depth = zeroblob(100) WHERE seq = " + std::to_string(seq));
  }
  void CorruptBlob(const std::string& kind, const std::string& sql_value) {
    ExecSql("UPDATE blobs SET data = " + sql_value + " WHERE kind = '" + kind + "'");
  }

  std::unique_ptr<testing::TestStore> store_;
  std::string db_;
  MapLayerOptions options_;
  MapInfo map_;
  SessionInfo session_;
  SqliteMapStore* read_ = nullptr;
  StorageWriter* writer_ = nullptr;
};

TEST(MapLayerOptionsTest, Validate) {
  EXPECT_TRUE(MapLayerOptions{}.Validate().ok());
  MapLayerOptions o;
  o.queue_capacity = 0;
  EXPECT_EQ(o.Validate().code(), StatusCode::kInvalidArgument);
  o = {};
  o.persist_interval_s = std::nan("");
  EXPECT_EQ(o.Validate().code(), StatusCode::kInvalidArgument);
  o = {};
  o.occupancy.resolution_m = 0;
  EXPECT_EQ(o.Validate().code(), StatusCode::kInvalidArgument);
  o = {};
  o.cloud.leaf_size_m = -1;
  EXPECT_EQ(o.Validate().code(), StatusCode::kInvalidArgument);
  EXPECT_EQ(MapLayerBuilder::Start(1, "m", {}, nullptr, StoreRestore::None()).status().code(),
            StatusCode::kInvalidArgument);
}

TEST_F(MapLayersTest, PersistedLayersEqualAFreshBuildWhateverTheArrivalOrder) {
  std::unique_ptr<MapLayerBuilder> builder = StartBuilder(/*restore=*/false);
  ASSERT_NE(builder, nullptr);
  Feed(*builder, /*drifted=*/false);
  ASSERT_TRUE(builder->Flush().ok());
  const MapLayerStats stats = builder->stats();
  EXPECT_EQ(stats.keyframes_inserted, Keyframes().size());
  EXPECT_EQ(stats.rebuilds, 0u);
  EXPECT_EQ(stats.persists, 1u);
  EXPECT_EQ(stats.insert_ms.count, Keyframes().size());

  const std::vector<KeyframeCloud> clouds = Clouds(options_);
  StatusOr<OccupancyMap> fresh = OccupancyMap::Build(FreshInput(clouds, false), options_.occupancy);
  ASSERT_TRUE(fresh.ok());
  const OccupancyMap stored = StoredOccupancy();
  EXPECT_EQ(Keys(stored), Keys(*fresh));
  EXPECT_GT(Keys(stored).size(), 1000u);
  // Space the first camera saw through is free.
  EXPECT_EQ(stored.Occupancy(Keyframes()[0].T_world_camera * Eigen::Vector3d(0, 0, 1)),
            VoxelState::kFree);

  StatusOr<PointCloudMap> cloud = PointCloudMap::Build(FreshInput(clouds, false), options_.cloud);
  ASSERT_TRUE(cloud.ok());
  testing::ExpectSameCloud(StoredCloud(), cloud->points(), options_.cloud.leaf_size_m, 2e-6, 1);
}

// KNOWN_POSES from GPS / UTM: the map frame's origin is thousands of kilometres away. The layers
// are built around the first keyframe (rounded to a kilometre) and equal a build of the room at
// home; the origin is stored with them and read back by a restarted builder and the exports.
TEST_F(MapLayersTest, LayersFarFromTheMapOriginAreBuiltAroundTheFirstKeyframe) {
  const Eigen::Vector3d utm(690000.0, 5335000.0, 0.0);
  Eigen::Isometry3d shift = Eigen::Isometry3d::Identity();
  shift.translation() = utm;
  std::unique_ptr<MapLayerBuilder> builder = StartBuilder(/*restore=*/false);
  ASSERT_NE(builder, nullptr);
  for (const Keyframe& k : Keyframes()) {
    ASSERT_TRUE(builder
                    ->AddKeyframeImages(session_.id, k.seq, {k.frame.depth, synth::kDepthScale},
                                        k.frame.bgr, SharedRenderer().camera())
                    .ok());
    ASSERT_TRUE(
        builder->SetKeyframePoses({{session_.id, k.seq, shift * k.T_world_camera}}, false).ok());
  }
  // One keyframe 1700 m further on: beyond the tree's reach at 5 cm, left out, not an error.
  const Keyframe& far = Keyframes()[3];
  Eigen::Isometry3d away = shift * far.T_world_camera;
  away.translation().x() += 1700.0;
  ASSERT_TRUE(builder
                  ->AddKeyframeImages(session_.id, 1000, {far.frame.depth, synth::kDepthScale},
                                      far.frame.bgr, SharedRenderer().camera())
                  .ok());
  ASSERT_TRUE(builder->SetKeyframePoses({{session_.id, 1000, away}}, false).ok());
  ASSERT_TRUE(builder->Flush().ok());
  EXPECT_EQ(builder->stats().keyframes_inserted, Keyframes().size());
  EXPECT_EQ(builder->stats().keyframes_beyond_reach, 1u);

  const std::vector<KeyframeCloud> clouds = Clouds(options_);
  StatusOr<OccupancyMap> fresh = OccupancyMap::Build(FreshInput(clouds, false), options_.occupancy);
  ASSERT_TRUE(fresh.ok());
  EXPECT_EQ(Keys(StoredOccupancy()), Keys(*fresh));
  StatusOr<MapBlob> origin = read_->GetBlob(map_.id, kLayerOriginBlobKind);
  ASSERT_TRUE(origin.ok()) << origin.status().ToString();
  EXPECT_EQ(DecodeLayerOrigin(origin->data).value(), utm);

  // Exports name the origin; a restarted builder keeps it.
  StatusOr<ExportResult> ot = Export("ot");
  ASSERT_TRUE(ot.ok()) << ot.status().ToString();
  EXPECT_EQ(ot->layer_origin, utm);
  builder.reset();
  builder = StartBuilder(/*restore=*/true);
  ASSERT_TRUE(builder->Flush().ok());
  EXPECT_EQ(DecodeLayerOrigin(read_->GetBlob(map_.id, kLayerOriginBlobKind)->data).value(), utm);
}

// A 1 mm cloud leaf indexes +-1049 m; the 5 cm tree reaches 1618 m. A keyframe 1200 m out is in
// the tree, its points are left out of the coloured cloud and counted (a warning says so), and
// the rest of the cloud is as it was.
TEST_F(MapLayersTest, CloudPointsBeyondTheLeafIndexAreLeftOutAndCounted) {
  options_.cloud.leaf_size_m = 0.001;
  std::unique_ptr<MapLayerBuilder> builder = StartBuilder(/*restore=*/false);
  ASSERT_NE(builder, nullptr);
  const Keyframe& home = Keyframes()[0];
  Eigen::Isometry3d away = home.T_world_camera;
  away.translation().x() += 1200.0;
  int64_t seq = 0;
  for (const Eigen::Isometry3d& T : {home.T_world_camera, away}) {
    ASSERT_TRUE(builder
                    ->AddKeyframeImages(session_.id, seq, {home.frame.depth, synth::kDepthScale},
                                        home.frame.bgr, SharedRenderer().camera())
                    .ok());
    ASSERT_TRUE(builder->SetKeyframePoses({{session_.id, seq++, T}}, false).ok());
  }
  ASSERT_TRUE(builder->Flush().ok());
  const MapLayerStats stats = builder->stats();
  EXPECT_EQ(stats.keyframes_inserted, 2u);
  EXPECT_EQ(stats.keyframes_beyond_reach, 0u);
  const std::vector<KeyframeCloud> clouds = Clouds(options_);
  EXPECT_EQ(stats.cloud_points_out_of_range, clouds[0].size());
  StatusOr<PointCloudMap> expected =
      PointCloudMap::Build({{&clouds[0], home.T_world_camera}}, options_.cloud);
  ASSERT_TRUE(expected.ok());
  testing::ExpectSameCloud(StoredCloud(), expected->points(), options_.cloud.leaf_size_m, 2e-6, 1);
}

TEST(LayerFrameTest, OriginsRoundToKilometresAndRoundTrip) {
  EXPECT_EQ(LayerOriginFor(Eigen::Vector3d(1.3, -0.6, 499.0)), Eigen::Vector3d::Zero());
  EXPECT_EQ(LayerOriginFor(Eigen::Vector3d(690123.4, 5334567.8, -2.0)),
            Eigen::Vector3d(690000, 5335000, 0));
  EXPECT_EQ(LayerOriginFor(Eigen::Vector3d(std::nan(""), 0, 0)), Eigen::Vector3d::Zero());
  const Eigen::Vector3d origin(690000, -5335000, 1000);
  EXPECT_EQ(DecodeLayerOrigin(EncodeLayerOrigin(origin)).value(), origin);
  for (const char* bad : {"", "semmap-layer-origin-v1 1 2\n", "semmap-layer-origin-v1 1 2 nan\n",
                          "semmap-layer-origin-v1 1 2 3\nextra", "other 1 2 3\n",
                          "semmap-layer-origin-v1 1 2 1e9\n"}) {
    EXPECT_EQ(DecodeLayerOrigin(bad).status().code(), StatusCode::kDataLoss) << bad;
  }
  OccupancyMapOptions options;  // 5 cm, 4 m range: OctoMap's +-1638 m less the ray
  EXPECT_NEAR(LayerReachM(options), 0.05 * 32768 * 0.99 - 4.0, 1e-9);
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.translation().y() = 1600;
  EXPECT_TRUE(WithinLayerReach(T, options));
  T.translation().y() = -1700;
  EXPECT_FALSE(WithinLayerReach(T, options));
}

TEST_F(MapLayersTest, CorrectionRebuildsTheMapToMatchAFreshBuildFromTheCorrectedPoses) {
  std::unique_ptr<MapLayerBuilder> builder = StartBuilder(/*restore=*/false);
  ASSERT_NE(builder, nullptr);
  Feed(*builder, /*drifted=*/true);
  ASSERT_TRUE(builder->Flush().ok());
  const std::vector<KeyframeCloud> clouds = Clouds(options_);
  StatusOr<OccupancyMap> drifted =
      OccupancyMap::Build(FreshInput(clouds, true), options_.occupancy);
  StatusOr<OccupancyMap> corrected =
      OccupancyMap::Build(FreshInput(clouds, false), options_.occupancy);
  ASSERT_TRUE(drifted.ok() && corrected.ok());
  EXPECT_EQ(Keys(StoredOccupancy()), Keys(*drifted));
  ASSERT_NE(Keys(*drifted), Keys(*corrected));

  // The back end's loop closure: every keyframe moves (two corrections, one rebuild).
  std::vector<KeyframePose> half, rest;
  for (const Keyframe& k : Keyframes()) {
    (k.seq < 60 ? half : rest).push_back({session_.id, k.seq, k.T_world_camera});
  }
  ASSERT_TRUE(builder->SetKeyframePoses(half, true).ok());
  ASSERT_TRUE(builder->SetKeyframePoses(rest, true).ok());
  ASSERT_TRUE(builder->Flush().ok());
  EXPECT_EQ(Keys(StoredOccupancy()), Keys(*corrected));
  StatusOr<PointCloudMap> cloud = PointCloudMap::Build(FreshInput(clouds, false), options_.cloud);
  ASSERT_TRUE(cloud.ok());
  testing::ExpectSameCloud(StoredCloud(), cloud->points(), options_.cloud.leaf_size_m, 2e-6, 1);
  const MapLayerStats stats = builder->stats();
  EXPECT_LE(stats.rebuilds, 2u);
  EXPECT_GE(stats.rebuilds, 1u);
  EXPECT_EQ(stats.rebuild_ms.count, stats.rebuilds);

  // A correction that moves nothing costs no rebuild.
  const uint64_t rebuilds = stats.rebuilds;
  ASSERT_TRUE(builder->SetKeyframePoses(rest, true).ok());
  ASSERT_TRUE(builder->Flush().ok());
  EXPECT_EQ(builder->stats().rebuilds, rebuilds);

  // Bundle adjustment's refinements: 6 mm each, no rebuild, until together they leave a
  // keyframe more than rebuild_min_translation_m from where the tree holds it.
  const int steps_below = static_cast<int>(options_.rebuild_min_translation_m / 0.006);
  for (int step = 1; step <= steps_below + 1; ++step) {
    std::vector<KeyframePose> nudged = rest;
    for (KeyframePose& p : nudged) p.T_world_keyframe.translation().x() += 0.006 * step;
    ASSERT_TRUE(builder->SetKeyframePoses(nudged, true).ok());
    ASSERT_TRUE(builder->Flush().ok());
    EXPECT_EQ(builder->stats().rebuilds, rebuilds + (step > steps_below ? 1 : 0)) << step;
    // The coloured cloud follows every nudge without a rebuild: a fresh build at those poses.
    std::vector<std::pair<const KeyframeCloud*, Eigen::Isometry3d>> at_nudged =
        FreshInput(clouds, false);
    for (size_t i = 0, r = 0; i < at_nudged.size(); ++i) {
      if (r < nudged.size() && nudged[r].seq == Keyframes()[i].seq) {
        at_nudged[i].second = nudged[r++].T_world_keyframe;
      }
    }
    StatusOr<PointCloudMap> expected = PointCloudMap::Build(at_nudged, options_.cloud);
    ASSERT_TRUE(expected.ok());
    testing::ExpectSameCloud(StoredCloud(), expected->points(), options_.cloud.leaf_size_m, 2e-6,
                             1);
  }
}

TEST_F(MapLayersTest, RestartedBuilderRestoresFromStoredKeyframes) {
  StoreKeyframes(/*drifted=*/false);
  std::unique_ptr<MapLayerBuilder> builder = StartBuilder(/*restore=*/true);
  ASSERT_NE(builder, nullptr);
  ASSERT_TRUE(builder->Flush().ok());
  EXPECT_EQ(builder->stats().restored_keyframes, Keyframes().size());
  const std::vector<KeyframeCloud> clouds = Clouds(options_);
  StatusOr<OccupancyMap> fresh = OccupancyMap::Build(FreshInput(clouds, false), options_.occupancy);
  ASSERT_TRUE(fresh.ok());
  EXPECT_EQ(Keys(StoredOccupancy()), Keys(*fresh));

  // Restored keyframes take corrections like new ones.
  std::vector<KeyframePose> moved;
  for (const Keyframe& k : Keyframes()) moved.push_back({session_.id, k.seq, Drifted(k)});
  ASSERT_TRUE(builder->SetKeyframePoses(moved, true).ok());
  ASSERT_TRUE(builder->Flush().ok());
  StatusOr<OccupancyMap> drifted =
      OccupancyMap::Build(FreshInput(clouds, true), options_.occupancy);
  ASSERT_TRUE(drifted.ok());
  EXPECT_EQ(Keys(StoredOccupancy()), Keys(*drifted));
}

// The cloud after each BA-sized nudge of every keyframe, against a fresh PCL build at the nudged
// poses (colours within `colour_tolerance`).
void ExpectCloudFollowsNudges(MapLayerBuilder& builder, int64_t session_id,
                              const std::vector<KeyframeCloud>& clouds,
                              const MapLayerOptions& options,
                              const std::function<std::vector<CloudPoint>()>& stored_cloud,
                              int colour_tolerance) {
  for (int step = 1; step <= 2; ++step) {
    std::vector<KeyframePose> nudged;
    std::vector<std::pair<const KeyframeCloud*, Eigen::Isometry3d>> expected_input;
    for (size_t i = 0; i < clouds.size(); ++i) {
      const Keyframe& k = Keyframes()[i];
      Eigen::Isometry3d T = k.T_world_camera;
      T.translation().x() += 0.006 * step;
      nudged.push_back({session_id, k.seq, T});
      expected_input.emplace_back(&clouds[i], T);
    }
    ASSERT_TRUE(builder.SetKeyframePoses(nudged, true).ok());
    ASSERT_TRUE(builder.Flush().ok());
    StatusOr<PointCloudMap> expected = PointCloudMap::Build(expected_input, options.cloud);
    ASSERT_TRUE(expected.ok());
    testing::ExpectSameCloud(stored_cloud(), expected->points(), options.cloud.leaf_size_m, 2e-6,
                             colour_tolerance);
  }
}

TEST_F(MapLayersTest, CloudsBeyondTheBudgetAreReadBackFromTheStoreForRebuildsAndMoves) {
  options_.keyframe_cloud_budget_bytes = 0;  // none kept once stored
  StoreKeyframes(/*drifted=*/true);
  std::unique_ptr<MapLayerBuilder> builder = StartBuilder(/*restore=*/false);
  ASSERT_NE(builder, nullptr);
  Feed(*builder, /*drifted=*/true);
  ASSERT_TRUE(builder->Flush().ok());
  MapLayerStats stats = builder->stats();  // the persist evicted every stored cloud
  EXPECT_EQ(stats.keyframes_inserted, Keyframes().size());
  EXPECT_EQ(stats.keyframes_evicted, Keyframes().size());
  EXPECT_EQ(stats.keyframe_cloud_bytes, 0u);
  EXPECT_EQ(stats.keyframe_cloud_reads, Keyframes().size());  // each checked once: the same
  EXPECT_EQ(stats.cloud_colour_swaps, 0u);

  // The loop closure's rebuild reads every cloud back: the layers of a fresh build.
  std::vector<KeyframePose> corrected;
  for (const Keyframe& k : Keyframes()) corrected.push_back({session_.id, k.seq, k.T_world_camera});
  ASSERT_TRUE(builder->SetKeyframePoses(corrected, true).ok());
  ASSERT_TRUE(builder->Flush().ok());
  stats = builder->stats();
  EXPECT_EQ(stats.rebuilds, 1u);
  EXPECT_EQ(stats.keyframes_evicted, Keyframes().size());
  EXPECT_EQ(stats.keyframe_cloud_bytes, 0u);
  EXPECT_EQ(stats.keyframe_cloud_reads, 2 * Keyframes().size());
  EXPECT_EQ(stats.keyframes_unreadable, 0u);
  const std::vector<KeyframeCloud> clouds = Clouds(options_);
  StatusOr<OccupancyMap> fresh = OccupancyMap::Build(FreshInput(clouds, false), options_.occupancy);
  ASSERT_TRUE(fresh.ok());
  EXPECT_EQ(Keys(StoredOccupancy()), Keys(*fresh));
  StatusOr<PointCloudMap> cloud = PointCloudMap::Build(FreshInput(clouds, false), options_.cloud);
  ASSERT_TRUE(cloud.ok());
  testing::ExpectSameCloud(StoredCloud(), cloud->points(), options_.cloud.leaf_size_m, 2e-6, 1);

  // Bundle adjustment's small moves read each moved keyframe back; the PNG-stored colours come
  // back exactly, so the cloud is a fresh build's.
  ExpectCloudFollowsNudges(
      *builder, session_.id, clouds, options_, [&] { return StoredCloud(); }, 1);
  EXPECT_EQ(builder->stats().keyframe_cloud_reads, 4 * Keyframes().size());
  EXPECT_EQ(builder->stats().rebuilds, 1u);
}

TEST_F(MapLayersTest, CloudsEvictedFromAJpegStoreTakeTheStoredColoursAndMoveExactly) {
  options_.keyframe_cloud_budget_bytes = 0;
  StoreKeyframes(/*drifted=*/false, "jpeg");  // what the store keeps of raw colour frames
  std::unique_ptr<MapLayerBuilder> builder = StartBuilder(/*restore=*/false);
  ASSERT_NE(builder, nullptr);
  Feed(*builder, /*drifted=*/false);
  ASSERT_TRUE(builder->Flush().ok());  // evicted: each read back once, its JPEG colours swapped in
  MapLayerStats stats = builder->stats();
  EXPECT_EQ(stats.keyframes_evicted, Keyframes().size());
  EXPECT_EQ(stats.cloud_colour_swaps, Keyframes().size());
  EXPECT_EQ(stats.keyframe_cloud_reads, Keyframes().size());
  // The clouds a read-back gives: the live points, the JPEG's colours.
  std::vector<KeyframeCloud> from_jpeg;
  for (const Keyframe& k : Keyframes()) {
    std::vector<uint8_t> jpeg;
    cv::imencode(".jpeg", k.frame.bgr, jpeg);
    StatusOr<KeyframeCloud> cloud =
        MakeKeyframeCloud({k.frame.depth, synth::kDepthScale}, cv::imdecode(jpeg, cv::IMREAD_COLOR),
                          SharedRenderer().camera(), options_.occupancy);
    ASSERT_TRUE(cloud.ok());
    from_jpeg.push_back(std::move(cloud).value());
  }
  ASSERT_NE(from_jpeg[0].colours, Clouds(options_)[0].colours);
  // Taken out and put back with the same colours: exactly a fresh build, no rebuild.
  ExpectCloudFollowsNudges(
      *builder, session_.id, from_jpeg, options_, [&] { return StoredCloud(); }, 1);
  stats = builder->stats();
  EXPECT_EQ(stats.rebuilds, 0u);
  EXPECT_EQ(stats.keyframe_cloud_reads, 3 * Keyframes().size());
}

TEST_F(MapLayersTest, CloudsNotYetStoredStayInMemoryWhateverTheBudget) {
  options_.keyframe_cloud_budget_bytes = 0;
  std::unique_ptr<MapLayerBuilder> builder = StartBuilder(/*restore=*/false);
  ASSERT_NE(builder, nullptr);
  Feed(*builder, /*drifted=*/false);  // the store has no keyframes: nothing can be read back
  ASSERT_TRUE(builder->Flush().ok());
  const MapLayerStats stats = builder->stats();
  EXPECT_EQ(stats.keyframes_evicted, 0u);
  EXPECT_GT(stats.keyframe_cloud_bytes, 12u * 1000);
}

TEST_F(MapLayersTest, RestoreReadsKeyframesOneAtATimeAndLeavesADamagedOneOut) {
  options_.keyframe_cloud_budget_bytes = 0;
  StoreKeyframes(/*drifted=*/false);
  // One keyframe's depth no longer decodes (stored that way, checksums do not cover images).
  CorruptKeyframeDepth(Keyframes()[3].seq);
  std::unique_ptr<MapLayerBuilder> builder = StartBuilder(/*restore=*/true);
  ASSERT_NE(builder, nullptr);
  ASSERT_TRUE(builder->Flush().ok());  // damage is a warning, not an error for the map
  const MapLayerStats stats = builder->stats();
  EXPECT_EQ(stats.restored_keyframes, Keyframes().size());
  EXPECT_EQ(stats.keyframes_unreadable, 1u);
  EXPECT_EQ(stats.keyframes_inserted, Keyframes().size() - 1);
  EXPECT_EQ(stats.keyframe_cloud_reads, Keyframes().size() - 1);
  EXPECT_EQ(stats.keyframe_cloud_bytes, 0u);
  std::vector<KeyframeCloud> clouds = Clouds(options_);
  clouds.erase(clouds.begin() + 3);
  std::vector<std::pair<const KeyframeCloud*, Eigen::Isometry3d>> input;
  for (size_t i = 0, c = 0; i < Keyframes().size(); ++i) {
    if (i != 3) input.emplace_back(&clouds[c++], Keyframes()[i].T_world_camera);
  }
  StatusOr<OccupancyMap> fresh = OccupancyMap::Build(input, options_.occupancy);
  ASSERT_TRUE(fresh.ok());
  EXPECT_EQ(Keys(StoredOccupancy()), Keys(*fresh));
  // Its pose still comes with corrections; it stays out without errors.
  std::vector<KeyframePose> moved;
  for (const Keyframe& k : Keyframes()) moved.push_back({session_.id, k.seq, Drifted(k)});
  ASSERT_TRUE(builder->SetKeyframePoses(moved, true).ok());
  EXPECT_TRUE(builder->Flush().ok());
  EXPECT_EQ(builder->stats().keyframes_inserted, Keyframes().size() - 1);
}

TEST_F(MapLayersTest, BadImagesAreReportedAtFlushAndTheBuilderCarriesOn) {
  std::unique_ptr<MapLayerBuilder> builder = StartBuilder(/*restore=*/false);
  ASSERT_NE(builder, nullptr);
  const Keyframe& k = Keyframes()[0];
  cv::Mat small_depth(10, 10, CV_16UC1, cv::Scalar(1000));
  ASSERT_TRUE(builder
                  ->AddKeyframeImages(session_.id, 1, {small_depth, synth::kDepthScale},
                                      k.frame.bgr, SharedRenderer().camera())
                  .ok());
  const Status flushed = builder->Flush();
  EXPECT_EQ(flushed.code(), StatusCode::kInvalidArgument) << flushed.ToString();
  Feed(*builder, false);
  EXPECT_TRUE(builder->Flush().ok());
  EXPECT_EQ(builder->stats().keyframes_inserted, Keyframes().size());
  builder->Stop();
  EXPECT_EQ(builder->SetKeyframePoses({}, false).code(), StatusCode::kUnavailable);
  EXPECT_EQ(builder->Flush().code(), StatusCode::kUnavailable);
}

TEST_F(MapLayersTest, ExportsReadBackWithOctoMapAndPcl) {
  StoreKeyframes(false);
  {
    std::unique_ptr<MapLayerBuilder> builder = StartBuilder(/*restore=*/true);
    ASSERT_NE(builder, nullptr);
    ASSERT_TRUE(builder->Flush().ok());
  }
  const OccupancyMap stored = StoredOccupancy();

  StatusOr<ExportResult> ot = Export("ot");
  ASSERT_TRUE(ot.ok()) << ot.status().ToString();
  std::istringstream ot_in(ot->bytes);
  std::unique_ptr<octomap::AbstractOcTree> tree(octomap::AbstractOcTree::read(ot_in));
  ASSERT_NE(tree, nullptr);
  EXPECT_GT(tree->size(), 1000u);
  EXPECT_NEAR(tree->getResolution(), 0.05, 1e-9);

  StatusOr<ExportResult> bt = Export("bt");
  ASSERT_TRUE(bt.ok()) << bt.status().ToString();
  octomap::OcTree bt_tree(0.1);
  std::istringstream bt_in(bt->bytes);
  ASSERT_TRUE(bt_tree.readBinary(bt_in));
  // Maximum-likelihood copy: the stored map's occupied space is occupied in it.
  int checked = 0;
  for (const OccupancyMap::Voxel& v : stored.OccupiedVoxels()) {
    if (++checked > 200) break;
    octomap::OcTreeNode* node = bt_tree.search(v.centre.x(), v.centre.y(), v.centre.z());
    ASSERT_NE(node, nullptr);
    EXPECT_TRUE(bt_tree.isNodeOccupied(node));
  }

  const std::vector<CloudPoint> cloud = StoredCloud();
  for (const bool ascii : {false, true}) {
    for (const std::string format : {"ply", "pcd"}) {
      ExportRequest request;
      request.map = map_.name;
      request.format = format;
      request.ascii = ascii;
      StatusOr<ExportResult> result = BuildExport(*read_, request, options_);
      ASSERT_TRUE(result.ok()) << result.status().ToString();
      const std::string path = store_->dir.File("cloud." + format);
      {
        std::ofstream out(path, std::ios::binary);
        out << result->bytes;
      }
      pcl::PointCloud<pcl::PointXYZRGB> read;
      const int rc =
          format == "ply" ? pcl::io::loadPLYFile(path, read) : pcl::io::loadPCDFile(path, read);
      ASSERT_EQ(rc, 0) << format << (ascii ? " ascii" : " binary");
      ASSERT_EQ(read.size(), cloud.size());
      EXPECT_NEAR(read[7].x, cloud[7].x, 1e-5);
      EXPECT_EQ(read[7].r, cloud[7].r);
    }
  }

  // Another leaf size filters again (fewer points); one session rebuilds from its keyframes.
  StatusOr<ExportResult> coarse = Export("pcd", "", 0.1);
  ASSERT_TRUE(coarse.ok()) << coarse.status().ToString();
  StatusOr<std::vector<CloudPoint>> coarse_points = ReadCloudPcd(coarse->bytes);
  ASSERT_TRUE(coarse_points.ok());
  EXPECT_LT(coarse_points->size(), cloud.size() / 4);
  StatusOr<ExportResult> session = Export("pcd", "lap");
  ASSERT_TRUE(session.ok()) << session.status().ToString();
  StatusOr<std::vector<CloudPoint>> session_points = ReadCloudPcd(session->bytes);
  ASSERT_TRUE(session_points.ok());
  testing::ExpectSameCloud(*session_points, cloud, options_.cloud.leaf_size_m, 2e-6, 1);
  StatusOr<ExportResult> fine_ot = Export("ot", "", 0.1);
  ASSERT_TRUE(fine_ot.ok()) << fine_ot.status().ToString();
  StatusOr<OccupancyMap> fine = OccupancyMap::DeserializeOt(fine_ot->bytes);
  ASSERT_TRUE(fine.ok());
  EXPECT_NEAR(fine->resolution(), 0.1, 1e-9);

  StatusOr<ExportResult> png = Export("png");
  ASSERT_TRUE(png.ok()) << png.status().ToString();
  EXPECT_EQ(png->media_type, "image/png");
  const cv::Mat image =
      cv::imdecode(std::vector<uint8_t>(png->bytes.begin(), png->bytes.end()), cv::IMREAD_COLOR);
  ASSERT_FALSE(image.empty());
  EXPECT_EQ(std::max(image.cols, image.rows), 1600);
  EXPECT_FALSE(ot->sha256_hex.empty());

  EXPECT_EQ(Export("ply", "nope").status().code(), StatusCode::kNotFound);
  EXPECT_EQ(Export("ply", "", -1).status().code(), StatusCode::kInvalidArgument);
  EXPECT_EQ(Export("ply", "", 5).status().code(), StatusCode::kInvalidArgument);
  EXPECT_EQ(Export("obj").status().code(), StatusCode::kInvalidArgument);
  ExportRequest bad_view;
  bad_view.map = map_.name;
  bad_view.format = "png";
  bad_view.view = "side";
  EXPECT_EQ(BuildExport(*read_, bad_view, options_).status().code(), StatusCode::kInvalidArgument);
}

// A cancelled export stops between keyframes: the check is asked again and again while a
// layer is rebuilt, and its status (not a partial export) is the answer.
TEST_F(MapLayersTest, RebuildingExportsStopWhenCancelled) {
  StoreKeyframes(false);
  for (const std::string format : {"ot", "ply", "png"}) {
    for (const int cancel_after : {0, 3}) {
      int asked = 0;
      ExportRequest request;
      request.map = map_.name;
      request.format = format;
      request.session = session_.name;  // a rebuild from the stored keyframes
      const CancelCheck cancel = [&]() -> Status {
        return ++asked > cancel_after ? CancelledError("gone") : OkStatus();
      };
      const StatusOr<ExportResult> result = BuildExport(*read_, request, options_, cancel);
      EXPECT_EQ(result.status().code(), StatusCode::kCancelled) << format << " " << cancel_after;
      EXPECT_EQ(asked, cancel_after + 1) << format << ": it went on after the cancellation";
    }
    // Never cancelled: the same export completes, having asked once per keyframe or more.
    int asked = 0;
    ExportRequest request;
    request.map = map_.name;
    request.format = format;
    request.session = session_.name;
    const StatusOr<ExportResult> whole = BuildExport(*read_, request, options_, [&] {
      ++asked;
      return OkStatus();
    });
    ASSERT_TRUE(whole.ok()) << whole.status().ToString();
    EXPECT_GE(asked, 4) << format;
  }
}

TEST_F(MapLayersTest, MapWithoutLayersIsNotFound) {
  EXPECT_EQ(Export("ot").status().code(), StatusCode::kNotFound);
  EXPECT_EQ(Export("ply").status().code(), StatusCode::kNotFound);
  // The picture still shows what there is (no cloud, no poses): not an error.
  EXPECT_TRUE(Export("png").ok());
}

TEST_F(MapLayersTest, DamagedBlobsAreDataLossNotACrash) {
  StoreKeyframes(false);
  {
    std::unique_ptr<MapLayerBuilder> builder = StartBuilder(/*restore=*/true);
    ASSERT_NE(builder, nullptr);
    ASSERT_TRUE(builder->Flush().ok());
  }
  // Bytes changed under the checksum.
  CorruptBlob(kOccupancyBlobKind, "zeroblob(length(data))");
  CorruptBlob(kCloudBlobKind, "substr(data, 1, length(data) / 2)");
  EXPECT_EQ(Export("ot").status().code(), StatusCode::kDataLoss);
  EXPECT_EQ(Export("bt").status().code(), StatusCode::kDataLoss);
  EXPECT_EQ(Export("ply").status().code(), StatusCode::kDataLoss);
  EXPECT_EQ(Export("png").status().code(), StatusCode::kDataLoss);

  // Damaged bytes with a matching checksum (stored that way): the layer readers catch them.
  WriteBatch batch;
  std::string truncated_ot;
  {
    StatusOr<OccupancyMap> map =
        OccupancyMap::Build(FreshInput(Clouds(options_), false), options_.occupancy);
    ASSERT_TRUE(map.ok());
    StatusOr<std::string> ot = map->SerializeOt();
    ASSERT_TRUE(ot.ok());
    truncated_ot = ot->substr(0, ot->size() - 1000);
  }
  batch.blobs.push_back({map_.id, kOccupancyBlobKind, truncated_ot, 1});
  batch.blobs.push_back({map_.id, kCloudBlobKind, "not a pcd", 1});
  ASSERT_TRUE(writer_->RunSync([&](MapStore& store) { return store.Write(batch).status(); }).ok());
  EXPECT_EQ(Export("ot").status().code(), StatusCode::kDataLoss);
  EXPECT_EQ(Export("pcd").status().code(), StatusCode::kDataLoss);
  // A session export rebuilds from the keyframes and does not need the blobs.
  EXPECT_TRUE(Export("ply", "lap").ok());
}

TEST(CloudPcdReaderTest, ReadsWhatPointCloudMapWritesAndRejectsTheRest) {
  std::vector<CloudPoint> points = {{1, 2, 3, 10, 20, 30}, {-1.5f, 0.25f, 4, 255, 0, 7}};
  const PointCloudMap map = PointCloudMap::FromPoints(points, {});
  StatusOr<std::string> pcd = map.ToPcd(true);
  ASSERT_TRUE(pcd.ok());
  StatusOr<std::vector<CloudPoint>> read = ReadCloudPcd(*pcd);
  ASSERT_TRUE(read.ok()) << read.status().ToString();
  EXPECT_EQ(PointKeys(*read), PointKeys(points));
  EXPECT_EQ(ReadCloudPcd(*map.ToPcd(false)).status().code(), StatusCode::kInvalidArgument);
  EXPECT_EQ(ReadCloudPcd(pcd->substr(0, pcd->size() - 3)).status().code(), StatusCode::kDataLoss);
  EXPECT_EQ(ReadCloudPcd(*pcd + "x").status().code(), StatusCode::kDataLoss);
  EXPECT_EQ(ReadCloudPcd("").status().code(), StatusCode::kInvalidArgument);
  std::string nan = *pcd;
  const float bad = std::nanf("");
  std::memcpy(&nan[nan.size() - 16], &bad, sizeof(bad));
  EXPECT_EQ(ReadCloudPcd(nan).status().code(), StatusCode::kDataLoss);
}

}  // namespace
}  // namespace semmap
