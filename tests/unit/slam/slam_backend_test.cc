// SlamBackend on synthetic keyframes of the default room with known poses: a drifting lap is
// closed by a verified loop and the optimised, stored poses land near the truth; a path that
// never revisits gets no loop; frames follow their keyframes; corrections reach the session.
#include "core/slam/slam_backend.h"

#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <map>
#include <set>

#include "core/slam/feature_codec.h"
#include "storage/sqlite/sqlite_map_store.h"
#include "tests/testing/temp_dir.h"
#include "tests/unit/odometry/odometry_test_util.h"

namespace semmap {
namespace {

using odometry_test::Circle;
using odometry_test::MakeRenderer;

constexpr int kLapFrames = 240;
constexpr int kKeyframeEvery = 8;

struct Keyframe {
  int64_t seq = 0;
  Eigen::Isometry3d T_true = Eigen::Isometry3d::Identity();
  std::shared_ptr<const FrameFeatures> features;
};

// Keyframes every `every` frames of the first `frames` (<= kLapFrames + 1) of a circle whose
// frame kLapFrames is back at frame 0's pose.
std::vector<Keyframe> RenderKeyframes(int frames, int every = kKeyframeEvery) {
  const CameraCalibration camera = synth::DefaultSyntheticCamera();
  synth::Renderer renderer = MakeRenderer(camera);
  StatusOr<FeatureExtractor> extractor = FeatureExtractor::Create({}, camera);
  EXPECT_TRUE(extractor.ok());
  const std::vector<StampedPose> poses = Circle(kLapFrames + 1);
  std::vector<Keyframe> out;
  for (int i = 0; i < frames; i += every) {
    const synth::RenderedFrame f = renderer.Render(poses[static_cast<size_t>(i)].T_world_camera);
    Keyframe kf;
    kf.seq = i;
    kf.T_true = poses[static_cast<size_t>(i)].T_world_camera;
    kf.features = std::make_shared<const FrameFeatures>(odometry_test::Extract(*extractor, f));
    out.push_back(std::move(kf));
  }
  return out;
}

// Odometry with a systematic heading drift (0.6 deg per keyframe about the vertical, world z)
// and 3 % too long steps: what a biased front end accumulates over a lap.
Eigen::Isometry3d DriftedStep(const Eigen::Isometry3d& T_true_step) {
  Eigen::Isometry3d step = T_true_step;
  step.translation() *= 1.03;
  // World z is the camera's -y (camera y points down).
  step.linear() = step.linear() *
                  Eigen::AngleAxisd(0.6 * M_PI / 180, -Eigen::Vector3d::UnitY()).toRotationMatrix();
  return step;
}

// Solves bounded by time converge as far as the machine's speed allows (sanitizer builds are
// several times slower): tests of what BA achieves let every solve run to convergence. The
// final BA (on by default: it runs at every Drain, i.e. after each keyframe of a paced
// stream) is off, so what the local BA does is what is measured; its own test turns it on.
SlamBackendOptions UnboundedSolves() {
  SlamBackendOptions options;
  options.local_ba.solver.max_solve_seconds = 0;
  options.local_ba.final_ba_max_solve_seconds = 0;
  options.local_ba.final_ba = false;
  return options;
}

class SlamBackendTest : public ::testing::Test {
 protected:
  void SetUp() override {
    auto store = SqliteMapStore::Open(dir_.File("semmap.db"), {});
    ASSERT_TRUE(store.ok()) << store.status().ToString();
    auto reader = SqliteMapStore::Open(dir_.File("semmap.db"), {});
    ASSERT_TRUE(reader.ok());
    reader_ = std::move(reader).value();
    auto writer = StorageWriter::Start(std::move(store).value(), {});
    ASSERT_TRUE(writer.ok());
    writer_ = std::move(writer).value();
    ASSERT_TRUE(writer_
                    ->RunSync([&](MapStore& s) -> Status {
                      SEMMAP_ASSIGN_OR_RETURN(MapInfo map, s.GetOrCreateMap("m"));
                      SessionInfo info;
                      info.map_id = map.id;
                      info.name = "s";
                      info.mode = SessionMode::kRgbd;
                      info.camera = synth::DefaultSyntheticCamera();
                      SEMMAP_ASSIGN_OR_RETURN(session_, s.CreateSession(info));
                      return OkStatus();
                    })
                    .ok());
  }

  // Streams the keyframes (and one in-between frame each) as a session would: rows first,
  // then the events. The "tracker" starts at T_first and accumulates drifted steps (exact ones
  // without drift). Returns the poses it reported.
  // With `point_ids`, each keyframe names its map points as a tracker would: keypoints with
  // depth whose true world positions fall in the same 1 cm cell share an id (from the second
  // half on, other ids with `rename_halfway`). `paced`: waits for the back end after each
  // keyframe, as a camera's frame rate does (else keyframes queue up).
  std::vector<Eigen::Isometry3d> Stream(SlamBackend& backend, const std::vector<Keyframe>& kfs,
                                        std::optional<Eigen::Isometry3d> T_first = std::nullopt,
                                        bool drift = true, bool point_ids = false,
                                        bool paced = false, bool rename_halfway = false) {
    std::vector<Eigen::Isometry3d> reported;
    std::map<std::array<int64_t, 3>, int64_t> id_of_cell;
    Eigen::Isometry3d T = T_first ? *T_first : kfs[0].T_true;
    for (size_t i = 0; i < kfs.size(); ++i) {
      const Eigen::Isometry3d true_step =
          i == 0 ? Eigen::Isometry3d::Identity() : kfs[i - 1].T_true.inverse() * kfs[i].T_true;
      const Eigen::Isometry3d step = drift ? DriftedStep(true_step) : true_step;
      if (i > 0) T = T * step;
      reported.push_back(T);
      // The frame after each keyframe sits 1 cm ahead of it.
      Eigen::Isometry3d T_kf_next = Eigen::Isometry3d::Identity();
      T_kf_next.translation().z() = 0.01;
      WriteBatch batch;
      TrajectoryPose pose{kfs[i].seq, 1000 + kfs[i].seq, T, true};
      TrajectoryPose next{kfs[i].seq + 1, 1001 + kfs[i].seq, T * T_kf_next, false};
      batch.frames = {{session_.id, pose}, {session_.id, next}};
      KeyframeRecord record;
      record.session_id = session_.id;
      record.seq = kfs[i].seq;
      record.stamp_ns = pose.stamp_ns;
      record.T_world_camera = T;
      record.features_format = std::string(kFeatureCodecFormat);
      record.features = EncodeFeatures(*kfs[i].features);
      batch.keyframes.push_back(record);
      EXPECT_TRUE(writer_->Submit(std::move(batch), [](const Status&, const WriteResult&) {}).ok());

      KeyframeEvent event;
      event.session_id = session_.id;
      event.seq = kfs[i].seq;
      event.T_world_keyframe = T;
      event.features = kfs[i].features;
      if (point_ids) {
        const FrameFeatures& f = *kfs[i].features;
        event.point_ids.assign(f.size(), -1);
        for (size_t k = 0; k < f.size(); ++k) {
          if (!f.has_depth[k]) continue;
          const Eigen::Vector3d p = kfs[i].T_true * f.points_camera[k] / 0.01;
          const std::array<int64_t, 3> cell{std::llround(p.x()), std::llround(p.y()),
                                            std::llround(p.z())};
          event.point_ids[k] =
              id_of_cell.emplace(cell, static_cast<int64_t>(id_of_cell.size())).first->second;
          // A tracker that forgot the first half names what it sees again anew.
          if (rename_halfway && 2 * i >= kfs.size()) event.point_ids[k] += 1'000'000;
        }
      }
      if (i > 0) event.previous_seq = kfs[i - 1].seq;
      event.T_previous_keyframe = step;
      event.information = Eigen::Matrix<double, 6, 6>::Identity() * odometry_information_;
      EXPECT_TRUE(backend.AddKeyframe(event).ok());
      EXPECT_TRUE(
          backend.AddFrame({session_.id, kfs[i].seq, kfs[i].seq, Eigen::Isometry3d::Identity(), T})
              .ok());
      EXPECT_TRUE(
          backend.AddFrame({session_.id, kfs[i].seq + 1, kfs[i].seq, T_kf_next, T * T_kf_next})
              .ok());
      if (paced) {
        EXPECT_TRUE(backend.Drain().ok());
      }
    }
    // The frames and keyframes written above are committed before anything reads them: the
    // back end's Drain waits for its own writes only (none, when nothing moved).
    EXPECT_TRUE(writer_->RunSync([](MapStore&) { return OkStatus(); }).ok());
    return reported;
  }

  // The fixture's map as a restarting server reads it back (on the writer's thread).
  StatusOr<MapSnapshot> ReadStoredMap() {
    StatusOr<MapSnapshot> snapshot = MapSnapshot{};
    const Status read = writer_->RunSync([&](MapStore& store) {
      snapshot = ReadMapSnapshot(store, session_.map_id);
      return snapshot.status();
    });
    if (!read.ok()) return read;
    return snapshot;
  }

  // Makes a session of a new map `name` the fixture's session.
  void StartNewMap(const std::string& name) {
    ASSERT_TRUE(writer_
                    ->RunSync([&](MapStore& s) -> Status {
                      SEMMAP_ASSIGN_OR_RETURN(MapInfo map, s.GetOrCreateMap(name));
                      session_.map_id = map.id;
                      return OkStatus();
                    })
                    .ok());
    StartNewSession("first");
  }

  // Makes `name` the fixture's session (a new one of the same map and camera).
  void StartNewSession(const std::string& name) {
    ASSERT_TRUE(writer_
                    ->RunSync([&](MapStore& s) -> Status {
                      SessionInfo info = session_;
                      info.name = name;
                      SEMMAP_ASSIGN_OR_RETURN(session_, s.CreateSession(info));
                      return OkStatus();
                    })
                    .ok());
  }

  std::unique_ptr<SlamBackend> Start(SlamBackendOptions options = {},
                                     std::shared_ptr<const BowVocabulary> vocabulary = nullptr,
                                     const MapSnapshot* snapshot = nullptr,
                                     StoreRestore from_store = {}) {
    SlamRestore restore;
    restore.snapshot = snapshot;
    restore.from_store = std::move(from_store);
    auto backend = SlamBackend::Start(session_.map_id, options, std::move(vocabulary),
                                      writer_.get(), std::move(restore));
    EXPECT_TRUE(backend.ok()) << backend.status().ToString();
    (*backend)->RegisterSession(
        session_.id, synth::DefaultSyntheticCamera(),
        [this](const Eigen::Isometry3d& T) {
          ++corrections_;
          last_correction_ = T;
        },
        [this](std::shared_ptr<const LocalMapUpdate> update) {
          ++map_updates_;
          last_map_update_ = std::move(update);
        });
    return std::move(backend).value();
  }

  // The committed vocabulary; null (a failure recorded) when it does not load.
  static std::shared_ptr<const BowVocabulary> Words() {
    StatusOr<BowVocabulary> vocabulary =
        BowVocabulary::Load(std::string(SEMMAP_SOURCE_DIR) + "/models/orb_vocab.bin");
    if (!vocabulary.ok()) {
      ADD_FAILURE() << vocabulary.status().ToString();
      return nullptr;
    }
    return std::make_shared<const BowVocabulary>(std::move(vocabulary).value());
  }

  double MaxError(const std::vector<Keyframe>& kfs, const std::vector<Eigen::Isometry3d>& T) {
    double worst = 0;
    for (size_t i = 0; i < kfs.size(); ++i) {
      worst = std::max(worst, (kfs[i].T_true.translation() - T[i].translation()).norm());
    }
    return worst;
  }

  testing::TempDir dir_;
  std::unique_ptr<SqliteMapStore> reader_;
  std::unique_ptr<StorageWriter> writer_;
  SessionInfo session_;
  double odometry_information_ = 1e4;  // 1 cm, 0.01 rad
  int corrections_ = 0;
  Eigen::Isometry3d last_correction_ = Eigen::Isometry3d::Identity();
  int map_updates_ = 0;
  std::shared_ptr<const LocalMapUpdate> last_map_update_;
};

TEST_F(SlamBackendTest, DriftingLapIsClosedAndStoredPosesAreCorrected) {
  const std::vector<Keyframe> kfs = RenderKeyframes(kLapFrames + 1);
  SlamBackendOptions options;
  options.local_radius_m = 1.0;  // the drift moves the last keyframes ~0.5 m off the first
  std::unique_ptr<SlamBackend> backend = Start(options);
  const std::vector<Eigen::Isometry3d> reported = Stream(*backend, kfs);
  ASSERT_TRUE(backend->Drain().ok());
  const SlamBackendStats stats = backend->stats();
  EXPECT_GE(stats.loops_accepted, 1u);
  EXPECT_GE(stats.optimisations, 1u);
  EXPECT_GE(corrections_, 1);

  auto stored = reader_->ListKeyframes(session_.id, false);
  ASSERT_TRUE(stored.ok());
  ASSERT_EQ(stored->size(), kfs.size());
  std::vector<Eigen::Isometry3d> optimised;
  for (const KeyframeRecord& kf : *stored) optimised.push_back(kf.T_world_camera);
  const double before = MaxError(kfs, reported), after = MaxError(kfs, optimised);
  std::printf("lap of %zu keyframes: max position error %.3f m before, %.3f m after closure\n",
              kfs.size(), before, after);
  EXPECT_GT(before, 0.2);
  EXPECT_LT(after, 0.1);
  EXPECT_LT(after, before / 4);

  // The frame after each keyframe followed it.
  auto trajectory = reader_->GetTrajectory(session_.id, false);
  ASSERT_TRUE(trajectory.ok());
  ASSERT_EQ(trajectory->size(), 2 * kfs.size());
  for (size_t i = 0; i < kfs.size(); ++i) {
    const Eigen::Isometry3d rel =
        (*trajectory)[2 * i].T_world_camera.inverse() * (*trajectory)[2 * i + 1].T_world_camera;
    EXPECT_NEAR(rel.translation().z(), 0.01, 1e-6) << "frame " << (*trajectory)[2 * i + 1].seq;
    EXPECT_TRUE((*trajectory)[2 * i].T_world_camera.isApprox(optimised[i], 1e-9));
  }
  auto links = reader_->ListLinks(session_.map_id);
  ASSERT_TRUE(links.ok());
  int loops = 0;
  for (const LinkRecord& l : *links) loops += l.kind == LinkKind::kLoop;
  EXPECT_EQ(loops, static_cast<int>(stats.loops_accepted));
}

// A second session after a restart: the back end starts from the stored map, the new session
// begins in a frame of its own (its tracker knows nothing of the first), place recognition
// finds the first session's keyframes, and the closed loop brings the new session into the
// map's frame.
TEST_F(SlamBackendTest, SessionAfterRestartJoinsTheStoredMap) {
  const std::shared_ptr<const BowVocabulary> words = Words();
  ASSERT_NE(words, nullptr);
  const std::vector<Keyframe> lap = RenderKeyframes(kLapFrames + 1);
  {
    std::unique_ptr<SlamBackend> first = Start({}, words);
    Stream(*first, lap, std::nullopt, /*drift=*/false);
    ASSERT_TRUE(first->Drain().ok());
  }  // the server stops

  StatusOr<MapSnapshot> snapshot = ReadStoredMap();
  ASSERT_TRUE(snapshot.ok()) << snapshot.status().ToString();
  EXPECT_EQ(snapshot->keyframes.size(), lap.size());
  const int64_t first_session = session_.id;
  // The second session walks a third of the lap again, starting in a frame of its own.
  StartNewSession("again");
  corrections_ = 0;
  std::unique_ptr<SlamBackend> second = Start({}, words, &*snapshot);
  EXPECT_EQ(second->stats().restored_keyframes, lap.size());
  // With a vocabulary, each keyframe's words are in the place index: a few kB each.
  EXPECT_GT(second->stats().place_index_bytes, lap.size() * 2000);
  const std::vector<Keyframe> again(lap.begin() + 10, lap.begin() + 20);
  Stream(*second, again, Eigen::Isometry3d::Identity(), /*drift=*/false);
  ASSERT_TRUE(second->Drain().ok());
  const SlamBackendStats stats = second->stats();
  ASSERT_GE(stats.loops_accepted, 1u);
  EXPECT_TRUE(stats.loops.front().global);
  EXPECT_EQ(stats.loops.front().candidate_session_id, first_session);
  // Once joined, further loops with the stored map agree with the graph: they are optimised
  // in a batch (here: when the session drains), not one by one.
  EXPECT_GT(stats.loops_already_consistent, 0u);
  EXPECT_LT(stats.optimisations, stats.loops_accepted);
  EXPECT_GE(corrections_, 1);
  auto stored = reader_->ListKeyframes(session_.id, false);
  ASSERT_TRUE(stored.ok());
  ASSERT_EQ(stored->size(), again.size());
  double worst = 0;
  for (size_t i = 0; i < again.size(); ++i) {
    worst = std::max(
        worst, ((*stored)[i].T_world_camera.translation() - again[i].T_true.translation()).norm());
  }
  std::printf("second session joined the stored map: max position error %.4f m\n", worst);
  EXPECT_LT(worst, 0.02);
}

// A route driven again: the third session repeats the keyframes of the second, which repeated
// the first's. Its candidates match it far better than their own session's neighbours a
// keyframe step away (xi >> 1), but the earlier sessions' keyframes at the same view match it
// as well: counted as neighbours (xi_view_neighbours), they keep the loops from being read as
// spikes. Without them the third session has loops rejected by xi.
TEST_F(SlamBackendTest, AViewRepeatedBySeveralSessionsIsNotASpike) {
  const std::shared_ptr<const BowVocabulary> words = Words();
  ASSERT_NE(words, nullptr);
  const std::vector<Keyframe> lap = RenderKeyframes(kLapFrames + 1);
  const std::vector<Keyframe> again(lap.begin() + 10, lap.begin() + 20);
  std::map<bool, SlamBackendStats> before_third, after_third;
  for (const bool view_neighbours : {true, false}) {
    if (!view_neighbours) StartNewMap("route-without");
    SlamBackendOptions options;
    options.xi_view_neighbours = view_neighbours ? 2 : 0;
    std::unique_ptr<SlamBackend> backend = Start(options, words);
    for (int pass = 0; pass < 3; ++pass) {
      if (pass > 0) {
        StartNewSession("pass" + std::to_string(pass));
        backend->RegisterSession(
            session_.id, synth::DefaultSyntheticCamera(), [](const Eigen::Isometry3d&) {},
            [](const std::shared_ptr<const LocalMapUpdate>& /*update*/) {});
      }
      if (pass == 2) before_third[view_neighbours] = backend->stats();
      Stream(*backend, pass == 0 ? lap : again, Eigen::Isometry3d::Identity(), /*drift=*/false);
      ASSERT_TRUE(backend->Drain().ok());
    }
    after_third[view_neighbours] = backend->stats();
  }
  const auto third = [&](bool view, auto field) {
    return after_third[view].*field - before_third[view].*field;
  };
  const uint64_t accepted_with = third(true, &SlamBackendStats::loops_accepted);
  const uint64_t xi_with = third(true, &SlamBackendStats::rejected_xi);
  const uint64_t accepted_without = third(false, &SlamBackendStats::loops_accepted);
  const uint64_t xi_without = third(false, &SlamBackendStats::rejected_xi);
  std::printf(
      "third pass over a route: with view neighbours %llu loops accepted, %llu rejected by xi; "
      "without %llu, %llu\n",
      static_cast<unsigned long long>(accepted_with), static_cast<unsigned long long>(xi_with),
      static_cast<unsigned long long>(accepted_without),
      static_cast<unsigned long long>(xi_without));
  EXPECT_GT(xi_without, 0u);  // the case the view neighbours are for
  EXPECT_LT(xi_with, xi_without);
  EXPECT_GE(accepted_with, accepted_without);
}

// The final BA at a session's end adjusts that session's keyframes; an earlier session's stay
// exactly where its own final BA left them (a map revisited every day is not re-adjusted whole
// at the end of each visit, and its layers are not rebuilt for it).
TEST_F(SlamBackendTest, FinalBundleAdjustmentLeavesEarlierSessionsWhereTheyWere) {
  const std::vector<Keyframe> kfs = RenderKeyframes(kLapFrames / 2);
  SlamBackendOptions options = UnboundedSolves();
  options.local_ba.final_ba = true;
  std::unique_ptr<SlamBackend> backend = Start(options);
  const auto stored_poses = [&](int64_t session_id) {
    std::vector<Eigen::Isometry3d> poses;
    auto stored = reader_->ListKeyframes(session_id, false);
    if (stored.ok()) {
      for (const KeyframeRecord& kf : *stored) poses.push_back(kf.T_world_camera);
    }
    return poses;
  };
  Stream(*backend, kfs, std::nullopt, /*drift=*/true, /*point_ids=*/true);
  ASSERT_TRUE(backend->Drain().ok());
  const int64_t first = session_.id;
  const std::vector<Eigen::Isometry3d> first_before = stored_poses(first);
  ASSERT_EQ(first_before.size(), kfs.size());

  StartNewSession("second");
  backend->RegisterSession(
      session_.id, synth::DefaultSyntheticCamera(), [](const Eigen::Isometry3d&) {},
      [](const std::shared_ptr<const LocalMapUpdate>& /*update*/) {});
  const std::vector<Eigen::Isometry3d> reported =
      Stream(*backend, kfs, std::nullopt, /*drift=*/true, /*point_ids=*/true);
  ASSERT_TRUE(backend->Drain().ok());
  EXPECT_EQ(backend->stats().final_ba_runs, 2u);
  const std::vector<Eigen::Isometry3d> first_after = stored_poses(first);
  ASSERT_EQ(first_after.size(), first_before.size());
  for (size_t i = 0; i < first_before.size(); ++i) {
    EXPECT_TRUE(first_after[i].matrix() == first_before[i].matrix()) << "keyframe " << i;
  }
  EXPECT_LT(MaxError(kfs, stored_poses(session_.id)), MaxError(kfs, reported) / 4);
}

// The map points of a finished session are stored when it drains; a restarted server restores
// them with the keyframes, and once a later session's loop joins it to the map, that session's
// tracker is sent them (under foreign ids) to track against.
TEST_F(SlamBackendTest, MapPointsPersistAndReachALaterSessionsTracker) {
  const std::shared_ptr<const BowVocabulary> words = Words();
  ASSERT_NE(words, nullptr);
  const std::vector<Keyframe> lap = RenderKeyframes(kLapFrames + 1);
  size_t first_points = 0;
  {
    std::unique_ptr<SlamBackend> first = Start(UnboundedSolves(), words);
    Stream(*first, lap, std::nullopt, /*drift=*/false, /*point_ids=*/true);
    ASSERT_TRUE(first->Drain().ok());
    first_points = first->stats().map_points;
    EXPECT_GE(first->stats().map_point_saves, 1u);
    ASSERT_TRUE(first->Drain().ok());  // nothing changed: not written again
    EXPECT_EQ(first->stats().map_point_saves, 1u);
  }
  ASSERT_GT(first_points, 500u);
  auto stored_points = reader_->ListMapPoints(session_.map_id);
  ASSERT_TRUE(stored_points.ok()) << stored_points.status().ToString();
  EXPECT_EQ(stored_points->size(), first_points);

  StatusOr<MapSnapshot> snapshot = ReadStoredMap();
  ASSERT_TRUE(snapshot.ok()) << snapshot.status().ToString();
  StartNewSession("again");
  std::unique_ptr<SlamBackend> second = Start(UnboundedSolves(), words, &*snapshot);
  EXPECT_EQ(second->stats().restored_map_points, first_points);
  EXPECT_EQ(second->stats().map_points, first_points);
  const std::vector<Keyframe> again(lap.begin() + 10, lap.begin() + 20);
  Stream(*second, again, Eigen::Isometry3d::Identity(), /*drift=*/false, /*point_ids=*/true,
         /*paced=*/true);
  ASSERT_TRUE(second->Drain().ok());
  ASSERT_GE(second->stats().loops_accepted, 1u);
  ASSERT_NE(last_map_update_, nullptr);
  const auto foreign =
      std::count_if(last_map_update_->ids.begin(), last_map_update_->ids.end(),
                    [](int64_t id) { return id >= MapPoints::kForeignTrackerIdBase; });
  std::printf(
      "restored %zu map points; the later session's last map update: %zu points, %ld "
      "of the stored map\n",
      first_points, last_map_update_->ids.size(), static_cast<long>(foreign));
  EXPECT_GT(foreign, 100);
}

// Features beyond the memory budget are released and read back from the store where loop
// verification and the trackers' local maps need them: the same loops and poses as with every
// keyframe's features in memory, and a restored map's old keyframes still close loops.
TEST_F(SlamBackendTest, FeaturesBeyondTheBudgetAreReadBackWhereNeeded) {
  const std::shared_ptr<const BowVocabulary> words = Words();
  ASSERT_NE(words, nullptr);
  const std::vector<Keyframe> lap = RenderKeyframes(kLapFrames + 1);
  const auto run = [&](size_t budget) {
    SlamBackendOptions options = UnboundedSolves();
    options.local_radius_m = 1.0;
    options.features_memory_bytes = budget;
    std::unique_ptr<SlamBackend> backend = Start(options, words);
    Stream(*backend, lap, std::nullopt, /*drift=*/true, /*point_ids=*/true, /*paced=*/true);
    EXPECT_TRUE(backend->Drain().ok());
    return backend->stats();
  };
  const SlamBackendStats all = run(0);
  const int64_t first_session = session_.id;
  auto stored_all = reader_->ListKeyframes(session_.id, false);
  ASSERT_TRUE(stored_all.ok());
  StartNewSession("budgeted");          // the same lap again, in a session of its own
  const SlamBackendStats few = run(1);  // every keyframe's features released after it
  auto stored_few = reader_->ListKeyframes(session_.id, false);
  ASSERT_TRUE(stored_few.ok());
  std::printf(
      "lap of %zu keyframes: all in memory %zu loops, %.1f kB held; budget 1 byte: %zu loops, "
      "%.1f kB held, %lu released, %lu read back\n",
      lap.size(), static_cast<size_t>(all.loops_accepted), all.features_bytes / 1e3,
      static_cast<size_t>(few.loops_accepted), few.features_bytes / 1e3,
      static_cast<unsigned long>(few.features_released),
      static_cast<unsigned long>(few.features_read_back));
  EXPECT_EQ(all.features_released, 0u);
  EXPECT_GE(all.loops_accepted, 1u);
  EXPECT_EQ(few.loops_accepted, all.loops_accepted);
  EXPECT_EQ(few.map_points, all.map_points);
  EXPECT_GE(few.features_released, lap.size() - 1);
  EXPECT_GT(few.features_read_back, 0u);
  EXPECT_EQ(few.features_unreadable, 0u);
  EXPECT_EQ(few.features_bytes, 0u);
  ASSERT_EQ(stored_few->size(), stored_all->size());
  for (size_t i = 0; i < stored_all->size(); ++i) {
    // Read-back 3D points are floats: verification may differ below a micrometre.
    EXPECT_LT(((*stored_few)[i].T_world_camera.translation() -
               (*stored_all)[i].T_world_camera.translation())
                  .norm(),
              1e-4)
        << "keyframe " << i;
  }

  // After a restart, with a budget of about two keyframes: the restored keyframes' features go
  // once the map is loaded, and come back for the loop a later session closes with them and
  // for the stored points its tracker is sent. (The budgeted session only: the map points
  // stored are its back end's.)
  StatusOr<MapSnapshot> snapshot = MapSnapshot{};
  ASSERT_TRUE(writer_
                  ->RunSync([&](MapStore& store) {
                    snapshot = ReadMapSnapshot(store, session_.map_id, {first_session});
                    return snapshot.status();
                  })
                  .ok())
      << snapshot.status().ToString();
  StartNewSession("after restart");
  SlamBackendOptions options = UnboundedSolves();
  options.features_memory_bytes = 2 * lap.front().features->HeldBytes();
  std::unique_ptr<SlamBackend> later = Start(options, words, &*snapshot);
  EXPECT_GE(later->stats().features_released, lap.size() - 2);
  const std::vector<Keyframe> again(lap.begin() + 10, lap.begin() + 20);
  Stream(*later, again, Eigen::Isometry3d::Identity(), /*drift=*/false, /*point_ids=*/true,
         /*paced=*/true);
  ASSERT_TRUE(later->Drain().ok());
  const SlamBackendStats stats = later->stats();
  EXPECT_GE(stats.loops_accepted, 1u);
  EXPECT_GT(stats.features_read_back, 0u);
  EXPECT_EQ(stats.features_unreadable, 0u);
  EXPECT_LE(stats.features_bytes, options.features_memory_bytes);
  ASSERT_NE(last_map_update_, nullptr);
  const auto foreign =
      std::count_if(last_map_update_->ids.begin(), last_map_update_->ids.end(),
                    [](int64_t id) { return id >= MapPoints::kForeignTrackerIdBase; });
  EXPECT_GT(foreign, 100);
}

// The server's way: the back end reads the stored map itself, on its own thread through a read
// connection (the storage writer is not involved), ahead of the new session's events, leaving
// out the live session's keyframes (they arrive as events).
TEST_F(SlamBackendTest, RestoresFromTheStoreOnItsOwnThreadLeavingOutLiveSessions) {
  const std::vector<Keyframe> lap = RenderKeyframes(12);
  {
    std::unique_ptr<SlamBackend> first = Start();
    Stream(*first, lap, std::nullopt, /*drift=*/false);
    ASSERT_TRUE(first->Drain().ok());
  }
  const int64_t first_session = session_.id;
  StartNewSession("live");
  // The live session's first keyframe is committed before the restore reads.
  Stream(*Start(), {lap.front()}, std::nullopt, /*drift=*/false);
  ASSERT_TRUE(writer_->RunSync([](MapStore&) { return OkStatus(); }).ok());  // after the above
  SlamRestore restore;
  restore.from_store =
      StoreRestore::ThroughReader(SqliteMapStore::Opener(dir_.File("semmap.db"), {}));
  restore.skip_sessions = {session_.id};
  auto second = SlamBackend::Start(session_.map_id, {}, nullptr, writer_.get(), restore);
  ASSERT_TRUE(second.ok()) << second.status().ToString();
  ASSERT_TRUE((*second)->Drain().ok());  // the barrier is behind the restore
  const SlamBackendStats stats = (*second)->stats();
  EXPECT_EQ(stats.restored_keyframes, lap.size());  // the first session's, not the live one's
  EXPECT_EQ(stats.unreadable_keyframes, 0u);
  EXPECT_NE(first_session, session_.id);

  // A reader that cannot open: the back end still runs, and its first Drain says why.
  restore.from_store = StoreRestore::ThroughReader(
      []() -> StatusOr<std::unique_ptr<MapStore>> { return UnavailableError("no reader"); });
  auto third = SlamBackend::Start(session_.map_id, {}, nullptr, writer_.get(), restore);
  ASSERT_TRUE(third.ok());
  const Status drained = (*third)->Drain();
  EXPECT_EQ(drained.code(), StatusCode::kUnavailable);
  EXPECT_NE(drained.message().find("restoring the map's keyframes"), std::string::npos);
  EXPECT_TRUE((*third)->Drain().ok());
}

// The same drifting lap, but the odometry claims to be exact (and no noise floor relaxes it):
// the verified loop cannot be reconciled with it, so it is taken back: no link, no moved pose.
TEST_F(SlamBackendTest, LoopContradictedByTheOptimisedGraphIsTakenBack) {
  const std::vector<Keyframe> kfs = RenderKeyframes(kLapFrames + 1);
  SlamBackendOptions options;
  options.local_radius_m = 1.0;
  options.edge_sigma_floor_m = 0;
  options.edge_sigma_floor_rad = 0;
  odometry_information_ = 1e12;  // 1 micrometre
  std::unique_ptr<SlamBackend> backend = Start(options);
  const std::vector<Eigen::Isometry3d> reported = Stream(*backend, kfs);
  ASSERT_TRUE(backend->Drain().ok());
  const SlamBackendStats stats = backend->stats();
  EXPECT_GE(stats.rejected_inconsistent, 1u);
  EXPECT_EQ(stats.loops_accepted, 0u);
  EXPECT_TRUE(stats.loops.empty());
  auto links = reader_->ListLinks(session_.map_id);
  ASSERT_TRUE(links.ok());
  for (const LinkRecord& l : *links) EXPECT_EQ(l.kind, LinkKind::kOdometry);
  auto stored = reader_->ListKeyframes(session_.id, false);
  ASSERT_TRUE(stored.ok());
  ASSERT_EQ(stored->size(), kfs.size());
  for (size_t i = 0; i < kfs.size(); ++i) {
    EXPECT_TRUE((*stored)[i].T_world_camera.isApprox(reported[i], 1e-9)) << "keyframe " << i;
  }
}

TEST_F(SlamBackendTest, PathThatNeverRevisitsHasNoLoop) {
  const std::vector<Keyframe> kfs = RenderKeyframes(kLapFrames / 2);
  std::unique_ptr<SlamBackend> backend = Start();
  Stream(*backend, kfs);
  ASSERT_TRUE(backend->Drain().ok());
  const SlamBackendStats stats = backend->stats();
  EXPECT_EQ(stats.loops_accepted, 0u);
  EXPECT_EQ(stats.optimisations, 0u);
  EXPECT_EQ(corrections_, 0);
  // What it holds: every keyframe's features, at least their arrays' sizes and at most the
  // capacities' slack more (no vocabulary here: no place index; no point ids: no points).
  size_t feature_arrays = 0;
  for (const Keyframe& kf : kfs) {
    feature_arrays += kf.features->keypoints.size() * sizeof(cv::KeyPoint) +
                      kf.features->descriptors.total() +
                      kf.features->points_camera.size() * sizeof(Eigen::Vector3d);
  }
  std::printf("%zu keyframes: features %zu bytes (arrays %zu), place index %zu, map points %zu\n",
              kfs.size(), stats.features_bytes, feature_arrays, stats.place_index_bytes,
              stats.map_point_bytes);
  EXPECT_GE(stats.features_bytes, feature_arrays);
  EXPECT_LT(stats.features_bytes, feature_arrays * 3 / 2);
  EXPECT_LT(stats.place_index_bytes, 1000u);
}

// Local bundle adjustment over the keyframes' shared map points undoes most of a biased front
// end's drift on a path that never revisits (no loop can help there), moves the session's
// tracker and sends it the refined points.
TEST_F(SlamBackendTest, LocalBundleAdjustmentPullsADriftingPathTowardsTheTruth) {
  const std::vector<Keyframe> kfs = RenderKeyframes(kLapFrames / 2);
  std::unique_ptr<SlamBackend> backend = Start(UnboundedSolves());
  const std::vector<Eigen::Isometry3d> reported =
      Stream(*backend, kfs, std::nullopt, /*drift=*/true, /*point_ids=*/true, /*paced=*/true);
  ASSERT_TRUE(backend->Drain().ok());
  const SlamBackendStats stats = backend->stats();
  EXPECT_EQ(stats.loops_accepted, 0u);
  EXPECT_GE(stats.local_ba_runs, kfs.size() - 2);
  EXPECT_EQ(stats.local_ba_skipped, 0u);
  EXPECT_EQ(stats.local_ba_failures, 0u);
  EXPECT_GT(stats.map_points, 500u);
  EXPECT_GE(corrections_, 1);
  ASSERT_NE(last_map_update_, nullptr);
  EXPECT_GT(last_map_update_->ids.size(), 100u);
  EXPECT_EQ(last_map_update_->descriptors.rows, static_cast<int>(last_map_update_->ids.size()));

  auto stored = reader_->ListKeyframes(session_.id, false);
  ASSERT_TRUE(stored.ok());
  ASSERT_EQ(stored->size(), kfs.size());
  std::vector<Eigen::Isometry3d> adjusted;
  for (const KeyframeRecord& kf : *stored) adjusted.push_back(kf.T_world_camera);
  const double before = MaxError(kfs, reported), after = MaxError(kfs, adjusted);
  std::printf("half lap of %zu keyframes: max position error %.3f m drifting, %.3f m after BA\n",
              kfs.size(), before, after);
  EXPECT_GT(before, 0.1);
  EXPECT_LT(after, before / 4);
}

// The final BA at the session's end (Drain) adjusts its keyframes and points once more.
TEST_F(SlamBackendTest, FinalBundleAdjustmentRunsWhenTheSessionDrains) {
  const std::vector<Keyframe> kfs = RenderKeyframes(kLapFrames / 2);
  SlamBackendOptions options = UnboundedSolves();
  options.local_ba.final_ba = true;
  std::unique_ptr<SlamBackend> backend = Start(options);
  const std::vector<Eigen::Isometry3d> reported =
      Stream(*backend, kfs, std::nullopt, /*drift=*/true, /*point_ids=*/true, /*paced=*/true);
  // Paced streaming drained after every keyframe: each drain ran it on the new keyframes.
  EXPECT_EQ(backend->stats().final_ba_runs, kfs.size());
  ASSERT_TRUE(backend->Drain().ok());
  EXPECT_EQ(backend->stats().final_ba_runs, kfs.size());  // nothing new: not again
  auto stored = reader_->ListKeyframes(session_.id, false);
  ASSERT_TRUE(stored.ok());
  std::vector<Eigen::Isometry3d> adjusted;
  for (const KeyframeRecord& kf : *stored) adjusted.push_back(kf.T_world_camera);
  EXPECT_LT(MaxError(kfs, adjusted), MaxError(kfs, reported) / 4);
}

// Keyframes every other frame of a slow arc see much the same points: many are redundant and
// culled, and the stored trajectory (every frame, including those anchored to culled
// keyframes, which follow the previous kept one) stays as good as without culling. (The test's
// tracker names points by 1 cm cells of their true position, so a point near a cell boundary
// splits in two: 70-80 % of a keyframe's points reach 3 other keyframes here, not 90 %; the
// test culls at 60 %.)
TEST_F(SlamBackendTest, CullingDropsRedundantKeyframesAndKeepsTheTrajectory) {
  const std::vector<Keyframe> kfs = RenderKeyframes(61, /*every=*/2);
  const auto run = [&](bool cull, const std::string& session_name) {
    StartNewSession(session_name);
    SlamBackendOptions options = UnboundedSolves();
    options.culling.enabled = cull;
    options.culling.redundant_fraction = 0.6;
    std::unique_ptr<SlamBackend> backend = Start(options);
    Stream(*backend, kfs, std::nullopt, /*drift=*/true, /*point_ids=*/true, /*paced=*/true);
    EXPECT_TRUE(backend->Drain().ok());
    const SlamBackendStats stats = backend->stats();
    auto trajectory = reader_->GetTrajectory(session_.id, /*keyframes_only=*/false);
    EXPECT_TRUE(trajectory.ok());
    EXPECT_EQ(trajectory->size(), 2 * kfs.size());
    double worst = 0;
    for (const TrajectoryPose& pose : *trajectory) {
      const Keyframe& kf = kfs[static_cast<size_t>(pose.seq / 2)];
      Eigen::Isometry3d T_true = kf.T_true;
      if (pose.seq != kf.seq) T_true.translation() += kf.T_true.linear().col(2) * 0.01;
      worst = std::max(worst, (pose.T_world_camera.translation() - T_true.translation()).norm());
    }
    return std::make_pair(stats, worst);
  };
  const auto [kept_stats, kept_error] = run(false, "all kept");
  const auto [culled_stats, culled_error] = run(true, "culled");
  std::printf("%zu keyframes: %lu culled; max frame error %.4f m culled, %.4f m all kept\n",
              kfs.size(), static_cast<unsigned long>(culled_stats.keyframes_culled), culled_error,
              kept_error);
  EXPECT_EQ(kept_stats.keyframes_culled, 0u);
  EXPECT_GE(culled_stats.keyframes_culled, kfs.size() / 4);
  EXPECT_LT(culled_stats.map_point_observations, kept_stats.map_point_observations);
  // Culled keyframes release their features.
  EXPECT_LT(culled_stats.features_bytes, kept_stats.features_bytes);
  EXPECT_LT(culled_error, kept_error + 0.003);
  EXPECT_LT(culled_error, 0.03);

  // Culling is stored: the culled keyframes keep their rows but lose their features, and a
  // restarted back end restores them as pose nodes, not as full keyframes.
  auto stored = reader_->ListKeyframeFeatures(session_.id);
  ASSERT_TRUE(stored.ok()) << stored.status().ToString();
  ASSERT_EQ(stored->size(), kfs.size());
  size_t stored_culled = 0;
  for (const KeyframeRecord& kf : *stored) {
    if (kf.culled) ++stored_culled;
    EXPECT_EQ(kf.features.empty(), kf.culled) << "seq " << kf.seq;
  }
  EXPECT_EQ(stored_culled, culled_stats.keyframes_culled);
  StatusOr<MapSnapshot> snapshot = ReadStoredMap();
  ASSERT_TRUE(snapshot.ok()) << snapshot.status().ToString();
  StartNewSession("after restart");
  std::unique_ptr<SlamBackend> restarted = Start({}, nullptr, &*snapshot);
  const SlamBackendStats restored = restarted->stats();
  EXPECT_EQ(restored.restored_culled_keyframes,
            culled_stats.keyframes_culled + kept_stats.keyframes_culled);
  EXPECT_EQ(restored.restored_keyframes, 2 * kfs.size() - stored_culled);
}

// With loop-point fusion on, a closed lap's two sides share map points afterwards.
TEST_F(SlamBackendTest, AcceptedLoopFusesTheMapPointsOnBothSides) {
  const std::vector<Keyframe> kfs = RenderKeyframes(kLapFrames + 1);
  SlamBackendOptions options;
  options.local_radius_m = 1.0;
  options.local_ba.fuse_loop_points = true;
  options.local_ba.final_ba = false;  // paced: it would run after every keyframe
  std::unique_ptr<SlamBackend> backend = Start(options);
  // Ids from a tracker that forgot the start: the lap's second half names its points anew.
  Stream(*backend, kfs, std::nullopt, /*drift=*/true, /*point_ids=*/true, /*paced=*/true,
         /*rename_halfway=*/true);
  ASSERT_TRUE(backend->Drain().ok());
  const SlamBackendStats stats = backend->stats();
  EXPECT_GE(stats.loops_accepted, 1u);
  EXPECT_GT(stats.map_points_fused, 5u);  // 18-30 seen: BA solves are time-bounded
}

// A tracker that forgot what it saw names the same points anew: point fusion finds the
// duplicates by projection and fuses them, and the tracking map update retires the session's
// other names of each fused point, so the tracker drops its stale copies.
TEST_F(SlamBackendTest, PointFusionMergesRenamedPointsAndRetiresTheirOtherNames) {
  const std::vector<Keyframe> kfs = RenderKeyframes(kLapFrames / 2);
  SlamBackendOptions options = UnboundedSolves();
  options.local_ba.final_ba = false;  // paced: it would run after every keyframe
  options.point_fusion.enabled = true;
  std::unique_ptr<SlamBackend> backend = Start(options);
  Stream(*backend, kfs, std::nullopt, /*drift=*/false, /*point_ids=*/true, /*paced=*/true,
         /*rename_halfway=*/true);
  ASSERT_TRUE(backend->Drain().ok());
  const SlamBackendStats stats = backend->stats();
  EXPECT_GT(stats.map_points_fused_by_projection, 100u);
  ASSERT_NE(last_map_update_, nullptr);
  ASSERT_FALSE(last_map_update_->retired_ids.empty());
  const std::set<int64_t> published(last_map_update_->ids.begin(), last_map_update_->ids.end());
  for (int64_t id : last_map_update_->retired_ids) {
    EXPECT_EQ(published.count(id), 0u) << id;
    // A name this session's tracker gave, or a fused point's foreign name (any session may
    // have been sent it: the back end does not remember which were).
    EXPECT_TRUE(id < 2'000'000 || id >= MapPoints::kForeignTrackerIdBase) << id;
  }
}

// Keyframes arriving faster than BA finishes shrink its window or skip it: the back end keeps up.
TEST_F(SlamBackendTest, LocalBundleAdjustmentGivesWayWhenKeyframesQueueUp) {
  const std::vector<Keyframe> kfs = RenderKeyframes(kLapFrames / 2);
  std::unique_ptr<SlamBackend> backend = Start();
  Stream(*backend, kfs, std::nullopt, /*drift=*/true, /*point_ids=*/true, /*paced=*/false);
  ASSERT_TRUE(backend->Drain().ok());
  const SlamBackendStats stats = backend->stats();
  EXPECT_GT(stats.local_ba_skipped + stats.local_ba_shrunk, 0u);
  EXPECT_EQ(stats.keyframes, kfs.size());
}

TEST_F(SlamBackendTest, OptionsAreValidated) {
  SlamBackendOptions options;
  options.exclude_recent = 0;
  EXPECT_EQ(SlamBackend::Start(1, options, nullptr, writer_.get()).status().code(),
            StatusCode::kInvalidArgument);
  EXPECT_EQ(SlamBackend::Start(1, {}, nullptr, nullptr).status().code(),
            StatusCode::kInvalidArgument);
  options = {};
  options.verifier.max_xi = -1;
  EXPECT_EQ(SlamBackend::Start(1, options, nullptr, writer_.get()).status().code(),
            StatusCode::kInvalidArgument);
}

TEST_F(SlamBackendTest, EventsAfterStopAreRefused) {
  std::unique_ptr<SlamBackend> backend = Start();
  backend->Stop();
  EXPECT_EQ(backend->AddFrame({}).code(), StatusCode::kUnavailable);
  EXPECT_EQ(backend->Drain().code(), StatusCode::kUnavailable);
  KeyframeEvent no_features;
  EXPECT_EQ(backend->AddKeyframe(no_features).code(), StatusCode::kInvalidArgument);
}

}  // namespace
}  // namespace semmap
