// SqliteMapStore: every MapStore method, validation, atomicity, blob checksums, persistence.
#include "storage/sqlite/sqlite_map_store.h"

#include <gtest/gtest.h>

#include <bit>
#include <filesystem>
#include <limits>
#include <tuple>
#include <utility>
#include <vector>

#include "storage/sqlite/map_point_codec.h"
#include "storage/sqlite/transaction.h"
#include "tests/unit/storage/storage_test_util.h"

namespace semmap {
namespace {

using storage_test::ExpectPoseNear;
using storage_test::FramePose;
using storage_test::Keyframe;
using storage_test::NewSession;
using storage_test::PoseAt;
using storage_test::TempDir;

class SqliteMapStoreTest : public ::testing::Test {
 protected:
  void SetUp() override { Reopen(); }

  void Reopen() {
    store_.reset();
    auto store = SqliteMapStore::Open(path(), SqliteOptions{});
    ASSERT_TRUE(store.ok()) << store.status().ToString();
    store_ = std::move(store).value();
  }
  std::string path() const { return dir_.File("semmap.db"); }

  MapInfo Map(const std::string& name) {
    auto map = store_->GetOrCreateMap(name);
    EXPECT_TRUE(map.ok()) << map.status().ToString();
    return map.ok() ? *map : MapInfo{};
  }
  SessionInfo Session(const std::string& map, const std::string& name) {
    auto session = store_->CreateSession(NewSession(Map(map).id, name));
    EXPECT_TRUE(session.ok()) << session.status().ToString();
    return session.ok() ? *session : SessionInfo{};
  }
  WriteResult Write(const WriteBatch& batch) {
    auto result = store_->Write(batch);
    EXPECT_TRUE(result.ok()) << result.status().ToString();
    return result.ok() ? *result : WriteResult{};
  }
  int64_t Count(const std::string& table) {
    return *store_->connection().QueryInt64("SELECT COUNT(*) FROM " + table);
  }

  TempDir dir_;
  std::unique_ptr<SqliteMapStore> store_;
};

// --- open ---

TEST(SqliteMapStoreOpenTest, MissingDirectoryFailsClearly) {
  TempDir dir;
  auto store = SqliteMapStore::Open(dir.File("no/such/dir/semmap.db"), {});
  ASSERT_FALSE(store.ok());
  EXPECT_EQ(store.status().code(), StatusCode::kFailedPrecondition);
  EXPECT_NE(store.status().message().find("no/such/dir/semmap.db"), std::string::npos);
}

TEST(SqliteMapStoreOpenTest, EmptyPathIsInvalid) {
  EXPECT_EQ(SqliteMapStore::Open("", {}).status().code(), StatusCode::kInvalidArgument);
}

TEST(SqliteMapStoreOpenTest, DirectoryInsteadOfFileFails) {
  TempDir dir;
  auto store = SqliteMapStore::Open(dir.path(), {});
  ASSERT_FALSE(store.ok());
  EXPECT_EQ(store.status().code(), StatusCode::kFailedPrecondition) << store.status().ToString();
}

TEST(SqliteMapStoreOpenTest, SynchronousNormalOption) {
  TempDir dir;
  SqliteOptions options;
  options.synchronous_full = false;
  options.busy_timeout_ms = 750;
  auto store = SqliteMapStore::Open(dir.File("a.db"), options);
  ASSERT_OK(store.status());
  EXPECT_EQ(*(*store)->connection().QueryInt64("PRAGMA synchronous"), 1);
  EXPECT_EQ(*(*store)->connection().QueryInt64("PRAGMA busy_timeout"), 750);
}

// --- maps ---

TEST_F(SqliteMapStoreTest, GetOrCreateMapIsIdempotent) {
  const MapInfo a = Map("office");
  EXPECT_GT(a.id, 0);
  EXPECT_EQ(a.name, "office");
  EXPECT_GT(a.created_unix_ns, 0);
  EXPECT_EQ(a.session_count, 0);
  EXPECT_EQ(a.keyframe_count, 0);
  const MapInfo again = Map("office");
  EXPECT_EQ(again.id, a.id);
  EXPECT_EQ(again.created_unix_ns, a.created_unix_ns);
  EXPECT_EQ(store_->GetOrCreateMap("").status().code(), StatusCode::kInvalidArgument);
}

TEST_F(SqliteMapStoreTest, ListAndGetMaps) {
  EXPECT_TRUE(store_->ListMaps()->empty());
  Map("zeta");
  Map("alpha");
  auto maps = store_->ListMaps();
  ASSERT_OK(maps.status());
  ASSERT_EQ(maps->size(), 2u);
  EXPECT_EQ((*maps)[0].name, "alpha");
  EXPECT_EQ((*maps)[1].name, "zeta");
  auto zeta = store_->GetMap("zeta");
  ASSERT_OK(zeta.status());
  EXPECT_EQ(zeta->id, (*maps)[1].id);
  auto missing = store_->GetMap("nope");
  EXPECT_EQ(missing.status().code(), StatusCode::kNotFound);
  EXPECT_NE(missing.status().message().find("nope"), std::string::npos);
}

// --- sessions ---

TEST_F(SqliteMapStoreTest, CreateAndGetSessionRoundTrips) {
  const MapInfo map = Map("office");
  SessionInfo wanted = NewSession(map.id, "morning");
  auto created = store_->CreateSession(wanted);
  ASSERT_OK(created.status());
  EXPECT_GT(created->id, 0);
  EXPECT_EQ(created->map_name, "office");

  auto got = store_->GetSession("office", "morning");
  ASSERT_OK(got.status());
  EXPECT_EQ(got->id, created->id);
  EXPECT_EQ(got->map_id, map.id);
  EXPECT_EQ(got->map_name, "office");
  EXPECT_EQ(got->name, "morning");
  EXPECT_EQ(got->mode, SessionMode::kRgbd);
  EXPECT_EQ(got->camera.width, 640);
  EXPECT_EQ(got->camera.height, 480);
  EXPECT_EQ(got->camera.fx, 525);
  EXPECT_EQ(got->camera.fy, 526);
  EXPECT_EQ(got->camera.cx, 319.5);
  EXPECT_EQ(got->camera.cy, 239.5);
  EXPECT_EQ(got->camera.distortion, wanted.camera.distortion);
  EXPECT_EQ(got->depth_scale, 5000);
  EXPECT_EQ(got->started_unix_ns, wanted.started_unix_ns);
  EXPECT_EQ(got->ended_unix_ns, 0);
  EXPECT_EQ(got->frame_count, 0);
  EXPECT_EQ(got->keyframe_count, 0);
}

TEST_F(SqliteMapStoreTest, SessionStartDefaultsToNow) {
  SessionInfo s = NewSession(Map("m").id, "s");
  s.started_unix_ns = 0;
  auto created = store_->CreateSession(s);
  ASSERT_OK(created.status());
  EXPECT_GT(created->started_unix_ns, 0);
}

TEST_F(SqliteMapStoreTest, DuplicateSessionNameIsAlreadyExists) {
  Session("office", "run");
  auto duplicate = store_->CreateSession(NewSession(Map("office").id, "run"));
  EXPECT_EQ(duplicate.status().code(), StatusCode::kAlreadyExists);
  EXPECT_NE(duplicate.status().message().find("'office' already has a session named 'run'"),
            std::string::npos)
      << duplicate.status().message();
  // The same name in another map is fine.
  EXPECT_OK(store_->CreateSession(NewSession(Map("lab").id, "run")).status());
}

TEST_F(SqliteMapStoreTest, CreateSessionValidates) {
  EXPECT_EQ(store_->CreateSession(NewSession(999, "s")).status().code(), StatusCode::kNotFound);
  const int64_t map = Map("m").id;
  EXPECT_EQ(store_->CreateSession(NewSession(map, "")).status().code(),
            StatusCode::kInvalidArgument);
  SessionInfo bad_mode = NewSession(map, "s");
  bad_mode.mode = static_cast<SessionMode>(42);
  EXPECT_EQ(store_->CreateSession(bad_mode).status().code(), StatusCode::kInvalidArgument);
  SessionInfo nan_camera = NewSession(map, "s");
  nan_camera.camera.fx = std::numeric_limits<double>::quiet_NaN();
  EXPECT_EQ(store_->CreateSession(nan_camera).status().code(), StatusCode::kInvalidArgument);
  EXPECT_EQ(Count("sessions"), 0);
}

TEST_F(SqliteMapStoreTest, ListSessions) {
  Session("b-map", "one");
  Session("a-map", "two");
  Session("b-map", "three");
  auto of_b = store_->ListSessions("b-map");
  ASSERT_OK(of_b.status());
  ASSERT_EQ(of_b->size(), 2u);
  EXPECT_EQ((*of_b)[0].name, "one");  // creation order within a map
  EXPECT_EQ((*of_b)[1].name, "three");
  auto all = store_->ListSessions("");
  ASSERT_OK(all.status());
  ASSERT_EQ(all->size(), 3u);
  EXPECT_EQ((*all)[0].map_name, "a-map");
  EXPECT_EQ(store_->ListSessions("unknown").status().code(), StatusCode::kNotFound);
  Map("empty");
  auto none = store_->ListSessions("empty");
  ASSERT_OK(none.status());
  EXPECT_TRUE(none->empty());
}

TEST_F(SqliteMapStoreTest, GetSessionUnknownIsNotFound) {
  Session("m", "s");
  EXPECT_EQ(store_->GetSession("m", "other").status().code(), StatusCode::kNotFound);
  EXPECT_EQ(store_->GetSession("other", "s").status().code(), StatusCode::kNotFound);
}

TEST_F(SqliteMapStoreTest, EndSession) {
  const SessionInfo s = Session("m", "s");
  ASSERT_OK(store_->EndSession(s.id, 1'800'000'000'000'000'000, SessionEndReason::kCompleted, ""));
  EXPECT_EQ(store_->GetSession("m", "s")->ended_unix_ns, 1'800'000'000'000'000'000);
  EXPECT_EQ(store_->EndSession(999, 1, SessionEndReason::kCompleted, "").code(),
            StatusCode::kNotFound);
  EXPECT_EQ(store_->EndSession(s.id, 0, SessionEndReason::kCompleted, "").code(),
            StatusCode::kInvalidArgument);
}

TEST_F(SqliteMapStoreTest, EndReasonsAndMessagesAreStored) {
  const SessionInfo done = Session("m", "done");
  const SessionInfo failed = Session("m", "failed");
  const SessionInfo open = Session("m", "open");
  ASSERT_OK(store_->EndSession(done.id, 10, SessionEndReason::kCompleted, ""));
  ASSERT_OK(store_->EndSession(failed.id, 20, SessionEndReason::kError,
                               "INVALID_ARGUMENT: frame seq 3 has no timestamp"));
  // Only the server's start marks crashes; "open" cannot be a stored end.
  EXPECT_EQ(store_->EndSession(open.id, 30, SessionEndReason::kCrashed, "").code(),
            StatusCode::kInvalidArgument);
  EXPECT_EQ(store_->EndSession(open.id, 30, SessionEndReason::kUnspecified, "").code(),
            StatusCode::kInvalidArgument);
  EXPECT_EQ(store_->GetSession("m", "open")->end_reason, SessionEndReason::kUnspecified);
  Reopen();
  EXPECT_EQ(store_->GetSession("m", "done")->end_reason, SessionEndReason::kCompleted);
  const SessionInfo f = *store_->GetSession("m", "failed");
  EXPECT_EQ(f.end_reason, SessionEndReason::kError);
  EXPECT_EQ(f.end_message, "INVALID_ARGUMENT: frame seq 3 has no timestamp");
  EXPECT_EQ(f.ended_unix_ns, 20);
}

TEST_F(SqliteMapStoreTest, OpenSessionsAreMarkedCrashedOnce) {
  const SessionInfo done = Session("m", "done");
  Session("m", "left-open");
  ASSERT_OK(store_->EndSession(done.id, 10, SessionEndReason::kCompleted, ""));
  EXPECT_EQ(store_->MarkOpenSessionsCrashed().value(), 1);
  EXPECT_EQ(store_->MarkOpenSessionsCrashed().value(), 0);
  const SessionInfo crashed = *store_->GetSession("m", "left-open");
  EXPECT_EQ(crashed.end_reason, SessionEndReason::kCrashed);
  EXPECT_EQ(crashed.ended_unix_ns, 0);  // nobody knows when it stopped
  EXPECT_EQ(store_->GetSession("m", "done")->end_reason, SessionEndReason::kCompleted);
}

TEST_F(SqliteMapStoreTest, RemoveSessionTakesItsRowsAndTheMapsDerivedProducts) {
  const SessionInfo a = Session("m", "a");
  const SessionInfo b = Session("m", "b");
  const SessionInfo other = Session("other", "c");
  WriteBatch batch;
  for (int64_t seq = 0; seq < 4; ++seq) batch.frames.emplace_back(a.id, FramePose(seq, seq < 2));
  batch.frames.emplace_back(b.id, FramePose(0, true));
  batch.keyframes.push_back(Keyframe(a.id, 0));
  batch.keyframes.push_back(Keyframe(a.id, 1));
  batch.keyframes.push_back(Keyframe(b.id, 0));
  batch.keyframes.push_back(Keyframe(other.id, 0));
  LinkRecord link;
  link.map_id = a.map_id;
  link.from_session_id = a.id;
  link.from_seq = 1;
  link.to_session_id = b.id;
  link.to_seq = 0;
  link.kind = LinkKind::kLoop;
  batch.links.push_back(link);
  batch.blobs.push_back({a.map_id, "octomap.ot", "tree", 1});
  batch.blobs.push_back({other.map_id, "octomap.ot", "other tree", 1});
  Write(batch);

  StatusOr<RemovedCounts> removed = store_->RemoveSession(a.id);
  ASSERT_OK(removed.status());
  EXPECT_EQ(removed->map_id, a.map_id);
  EXPECT_EQ(removed->sessions, 1);
  EXPECT_EQ(removed->frames, 4);
  EXPECT_EQ(removed->keyframes, 2);
  EXPECT_EQ(store_->GetSession("m", "a").status().code(), StatusCode::kNotFound);
  EXPECT_EQ(store_->GetSession("m", "b")->frame_count, 1);
  EXPECT_EQ(Count("links"), 0);  // it named a removed keyframe
  EXPECT_EQ(store_->GetBlob(a.map_id, "octomap.ot").status().code(), StatusCode::kNotFound);
  EXPECT_EQ(store_->GetBlob(other.map_id, "octomap.ot")->data, "other tree");
  EXPECT_EQ(store_->RemoveSession(a.id).status().code(), StatusCode::kNotFound);
  ASSERT_OK(store_->IntegrityCheck());
}

TEST_F(SqliteMapStoreTest, RemoveMapTakesEverythingInIt) {
  const SessionInfo a = Session("m", "a");
  const SessionInfo b = Session("m", "b");
  const SessionInfo other = Session("other", "c");
  WriteBatch batch;
  batch.frames.emplace_back(a.id, FramePose(0, true));
  batch.frames.emplace_back(b.id, FramePose(0));
  batch.frames.emplace_back(other.id, FramePose(0));
  batch.keyframes.push_back(Keyframe(a.id, 0));
  batch.blobs.push_back({a.map_id, "cloud.pcd", "cloud", 1});
  Write(batch);
  StatusOr<RemovedCounts> removed = store_->RemoveMap(a.map_id);
  ASSERT_OK(removed.status());
  EXPECT_EQ(removed->sessions, 2);
  EXPECT_EQ(removed->frames, 2);
  EXPECT_EQ(removed->keyframes, 1);
  EXPECT_EQ(store_->GetMap("m").status().code(), StatusCode::kNotFound);
  EXPECT_EQ(Count("sessions"), 1);
  EXPECT_EQ(Count("frames"), 1);
  EXPECT_EQ(Count("blobs"), 0);
  EXPECT_EQ(store_->RemoveMap(a.map_id).status().code(), StatusCode::kNotFound);
  ASSERT_OK(store_->IntegrityCheck());
}

// --- frames and trajectory ---

TEST_F(SqliteMapStoreTest, TrajectoryInSeqOrderWithKeyframeFilter) {
  const SessionInfo s = Session("m", "s");
  WriteBatch batch;
  for (int64_t seq : {3, 0, 2, 1, 4}) batch.frames.emplace_back(s.id, FramePose(seq, seq % 2 == 0));
  EXPECT_TRUE(Write(batch).keyframe_ids.empty());

  auto all = store_->GetTrajectory(s.id, false);
  ASSERT_OK(all.status());
  ASSERT_EQ(all->size(), 5u);
  for (int64_t i = 0; i < 5; ++i) {
    const TrajectoryPose& p = (*all)[static_cast<size_t>(i)];
    EXPECT_EQ(p.seq, i);
    EXPECT_EQ(p.stamp_ns, FramePose(i).stamp_ns);
    EXPECT_EQ(p.is_keyframe, i % 2 == 0);
    ExpectPoseNear(p.T_world_camera, FramePose(i).T_world_camera);
  }
  auto keyframes = store_->GetTrajectory(s.id, true);
  ASSERT_OK(keyframes.status());
  ASSERT_EQ(keyframes->size(), 3u);
  EXPECT_EQ((*keyframes)[1].seq, 2);
  EXPECT_EQ(store_->GetSession("m", "s")->frame_count, 5);
  EXPECT_EQ(store_->GetTrajectory(999, false).status().code(), StatusCode::kNotFound);
}

TEST_F(SqliteMapStoreTest, ResentFrameReplacesTheOldOne) {
  const SessionInfo s = Session("m", "s");
  WriteBatch first;
  first.frames.emplace_back(s.id, FramePose(7));
  Write(first);
  WriteBatch again;
  TrajectoryPose moved = FramePose(7, /*is_keyframe=*/true);
  moved.T_world_camera = PoseAt(42.0, 1.0);
  moved.stamp_ns = 99;
  again.frames.emplace_back(s.id, moved);
  Write(again);
  auto trajectory = store_->GetTrajectory(s.id, false);
  ASSERT_OK(trajectory.status());
  ASSERT_EQ(trajectory->size(), 1u);
  EXPECT_EQ((*trajectory)[0].stamp_ns, 99);
  EXPECT_TRUE((*trajectory)[0].is_keyframe);
  ExpectPoseNear((*trajectory)[0].T_world_camera, moved.T_world_camera);
  EXPECT_EQ(store_->GetSession("m", "s")->frame_count, 1);
}

TEST_F(SqliteMapStoreTest, EmptyBatchIsFine) {
  auto result = store_->Write(WriteBatch{});
  ASSERT_OK(result.status());
  EXPECT_TRUE(result->keyframe_ids.empty());
}

TEST_F(SqliteMapStoreTest, UnknownSessionFailsTheWholeBatch) {
  const SessionInfo s = Session("m", "s");
  WriteBatch batch;
  batch.frames.emplace_back(s.id, FramePose(0));
  batch.frames.emplace_back(12345, FramePose(1));
  auto result = store_->Write(batch);
  EXPECT_EQ(result.status().code(), StatusCode::kNotFound);
  EXPECT_NE(result.status().message().find("session id 12345"), std::string::npos);
  EXPECT_EQ(Count("frames"), 0);  // the valid frame was rolled back with it
  EXPECT_FALSE(store_->connection().in_transaction());
}

TEST_F(SqliteMapStoreTest, InvalidFramesAreRejected) {
  const SessionInfo s = Session("m", "s");
  WriteBatch negative;
  negative.frames.emplace_back(s.id, FramePose(-1));
  EXPECT_EQ(store_->Write(negative).status().code(), StatusCode::kInvalidArgument);
  WriteBatch nan;
  TrajectoryPose p = FramePose(1);
  p.T_world_camera.translation().x() = std::numeric_limits<double>::quiet_NaN();
  nan.frames.emplace_back(s.id, p);
  auto result = store_->Write(nan);
  EXPECT_EQ(result.status().code(), StatusCode::kInvalidArgument);
  EXPECT_NE(result.status().message().find("frame seq 1 of session"), std::string::npos)
      << result.status().message();
  EXPECT_EQ(Count("frames"), 0);
}

// --- keyframes ---

TEST_F(SqliteMapStoreTest, KeyframeIdsInOrderAndReadBack) {
  const SessionInfo s = Session("m", "s");
  WriteBatch batch;
  for (int64_t seq : {10, 20, 30}) batch.keyframes.push_back(Keyframe(s.id, seq));
  batch.keyframes[1].colour = {};  // a keyframe without images is allowed
  batch.keyframes[1].depth = {};
  batch.keyframes[1].depth_scale = 0;
  const WriteResult result = Write(batch);
  ASSERT_EQ(result.keyframe_ids.size(), 3u);
  EXPECT_LT(result.keyframe_ids[0], result.keyframe_ids[1]);
  EXPECT_LT(result.keyframe_ids[1], result.keyframe_ids[2]);

  auto kf = store_->GetKeyframe(result.keyframe_ids[2]);
  ASSERT_OK(kf.status());
  const KeyframeRecord expected = Keyframe(s.id, 30);
  EXPECT_EQ(kf->id, result.keyframe_ids[2]);
  EXPECT_EQ(kf->session_id, s.id);
  EXPECT_EQ(kf->seq, 30);
  EXPECT_EQ(kf->stamp_ns, expected.stamp_ns);
  ExpectPoseNear(kf->T_world_camera, expected.T_world_camera);
  EXPECT_EQ(kf->colour.format, "jpeg");
  EXPECT_EQ(kf->colour.bytes, expected.colour.bytes);
  EXPECT_EQ(kf->depth.format, "png");
  EXPECT_EQ(kf->depth.bytes, expected.depth.bytes);  // embedded NUL and 0xff survive
  EXPECT_EQ(kf->depth_scale, 5000);

  auto bare = store_->GetKeyframe(result.keyframe_ids[1]);
  ASSERT_OK(bare.status());
  EXPECT_TRUE(bare->colour.empty());
  EXPECT_TRUE(bare->depth.empty());
  EXPECT_EQ(bare->colour.format, "");

  auto listed = store_->ListKeyframes(s.id, /*with_images=*/false);
  ASSERT_OK(listed.status());
  ASSERT_EQ(listed->size(), 3u);
  EXPECT_EQ((*listed)[0].seq, 10);
  EXPECT_EQ((*listed)[2].id, result.keyframe_ids[2]);
  EXPECT_TRUE((*listed)[2].colour.bytes.empty());
  EXPECT_EQ((*listed)[2].colour.format, "jpeg");
  auto with_images = store_->ListKeyframes(s.id, /*with_images=*/true);
  ASSERT_OK(with_images.status());
  EXPECT_EQ((*with_images)[2].colour.bytes, expected.colour.bytes);

  EXPECT_EQ(store_->GetSession("m", "s")->keyframe_count, 3);
  EXPECT_EQ(store_->GetMap("m")->keyframe_count, 3);
  EXPECT_EQ(store_->GetMap("m")->session_count, 1);
  EXPECT_EQ(store_->GetKeyframe(999).status().code(), StatusCode::kNotFound);
  EXPECT_EQ(store_->ListKeyframes(999, false).status().code(), StatusCode::kNotFound);
}

TEST_F(SqliteMapStoreTest, DuplicateKeyframeSeqFailsTheBatch) {
  const SessionInfo s = Session("m", "s");
  WriteBatch first;
  first.keyframes.push_back(Keyframe(s.id, 5));
  Write(first);
  WriteBatch second;
  second.frames.emplace_back(s.id, FramePose(6));
  second.keyframes.push_back(Keyframe(s.id, 5));
  auto result = store_->Write(second);
  EXPECT_EQ(result.status().code(), StatusCode::kAlreadyExists);
  EXPECT_NE(result.status().message().find("keyframe seq 5"), std::string::npos);
  EXPECT_EQ(Count("keyframes"), 1);
  EXPECT_EQ(Count("frames"), 0);
}

TEST_F(SqliteMapStoreTest, CountsPerMapAndSession) {
  const SessionInfo a = Session("m", "a");
  const SessionInfo b = Session("m", "b");
  const SessionInfo c = Session("other", "c");
  WriteBatch batch;
  for (int64_t seq = 0; seq < 4; ++seq) batch.frames.emplace_back(a.id, FramePose(seq));
  batch.frames.emplace_back(b.id, FramePose(0));
  batch.keyframes.push_back(Keyframe(a.id, 0));
  batch.keyframes.push_back(Keyframe(b.id, 0));
  batch.keyframes.push_back(Keyframe(c.id, 0));
  Write(batch);
  auto sessions = store_->ListSessions("m");
  ASSERT_OK(sessions.status());
  ASSERT_EQ(sessions->size(), 2u);
  EXPECT_EQ((*sessions)[0].frame_count, 4);
  EXPECT_EQ((*sessions)[0].keyframe_count, 1);
  EXPECT_EQ((*sessions)[1].frame_count, 1);
  EXPECT_EQ((*sessions)[1].keyframe_count, 1);
  auto maps = store_->ListMaps();
  ASSERT_OK(maps.status());
  EXPECT_EQ((*maps)[0].name, "m");
  EXPECT_EQ((*maps)[0].session_count, 2);
  EXPECT_EQ((*maps)[0].keyframe_count, 2);
  EXPECT_EQ((*maps)[1].session_count, 1);
  EXPECT_EQ((*maps)[1].keyframe_count, 1);
}

// --- links ---

Eigen::Matrix<double, 6, 6> Asymmetric() {
  Eigen::Matrix<double, 6, 6> m;
  for (int r = 0; r < 6; ++r) {
    for (int c = 0; c < 6; ++c) m(r, c) = r * 10 + c + 0.5;
  }
  return m;
}

TEST_F(SqliteMapStoreTest, LinksByIdAndBySeqWithinOneBatch) {
  const SessionInfo s = Session("m", "s");
  WriteBatch first;
  first.keyframes.push_back(Keyframe(s.id, 0));
  const int64_t kf0 = Write(first).keyframe_ids.at(0);

  WriteBatch second;
  second.keyframes.push_back(Keyframe(s.id, 1));
  LinkRecord odometry;  // from an earlier keyframe by id to this batch's keyframe by seq
  odometry.map_id = s.map_id;
  odometry.from_keyframe_id = kf0;
  odometry.to_session_id = s.id;
  odometry.to_seq = 1;
  odometry.T_from_to = PoseAt(0.5, 0.1);
  odometry.information = Asymmetric();
  LinkRecord loop;  // both ends by (session, seq)
  loop.map_id = s.map_id;
  loop.kind = LinkKind::kLoop;
  loop.from_session_id = s.id;
  loop.from_seq = 1;
  loop.to_session_id = s.id;
  loop.to_seq = 0;
  second.links = {odometry, loop};
  const int64_t kf1 = Write(second).keyframe_ids.at(0);

  auto links = store_->ListLinks(s.map_id);
  ASSERT_OK(links.status());
  ASSERT_EQ(links->size(), 2u);
  const LinkRecord& l0 = (*links)[0];
  EXPECT_GT(l0.id, 0);
  EXPECT_EQ(l0.map_id, s.map_id);
  EXPECT_EQ(l0.from_keyframe_id, kf0);
  EXPECT_EQ(l0.to_keyframe_id, kf1);
  EXPECT_EQ(l0.from_session_id, s.id);
  EXPECT_EQ(l0.from_seq, 0);
  EXPECT_EQ(l0.to_seq, 1);
  EXPECT_EQ(l0.kind, LinkKind::kOdometry);
  ExpectPoseNear(l0.T_from_to, odometry.T_from_to);
  EXPECT_EQ(l0.information, Asymmetric());  // bit-exact, orientation kept
  const LinkRecord& l1 = (*links)[1];
  EXPECT_EQ(l1.kind, LinkKind::kLoop);
  EXPECT_EQ(l1.from_keyframe_id, kf1);
  EXPECT_EQ(l1.to_keyframe_id, kf0);
  EXPECT_EQ(l1.information, (Eigen::Matrix<double, 6, 6>::Identity()));

  // The information column holds 36 little-endian doubles, row-major.
  auto raw = store_->connection().Prepare("SELECT information FROM links WHERE id = ?1");
  ASSERT_OK(raw.status());
  ASSERT_OK((*raw)->BindInt64(1, l0.id));
  ASSERT_TRUE(*(*raw)->Step());
  const std::string bytes = (*raw)->ColumnBlob(0);
  ASSERT_EQ(bytes.size(), 288u);
  uint64_t bits = 0;
  for (int b = 0; b < 8; ++b) bits |= uint64_t{static_cast<unsigned char>(bytes[8 + b])} << (8 * b);
  EXPECT_EQ(std::bit_cast<double>(bits), Asymmetric()(0, 1));
}

TEST_F(SqliteMapStoreTest, InvalidLinksFailTheBatch) {
  const SessionInfo s = Session("m", "s");
  const SessionInfo other = Session("elsewhere", "s");
  WriteBatch setup;
  setup.keyframes = {Keyframe(s.id, 0), Keyframe(other.id, 0)};
  const WriteResult ids = Write(setup);

  auto try_link = [&](const LinkRecord& link) {
    WriteBatch batch;
    batch.frames.emplace_back(s.id, FramePose(1));
    batch.links.push_back(link);
    return store_->Write(batch).status();
  };
  LinkRecord unknown;
  unknown.map_id = s.map_id;
  unknown.from_keyframe_id = ids.keyframe_ids[0];
  unknown.to_keyframe_id = 987654;
  Status status = try_link(unknown);
  EXPECT_EQ(status.code(), StatusCode::kNotFound);
  EXPECT_NE(status.message().find("to keyframe id 987654 not found"), std::string::npos)
      << status.message();

  LinkRecord unknown_seq = unknown;
  unknown_seq.to_keyframe_id = 0;
  unknown_seq.to_session_id = s.id;
  unknown_seq.to_seq = 77;
  EXPECT_EQ(try_link(unknown_seq).code(), StatusCode::kNotFound);

  LinkRecord unset = unknown;
  unset.to_keyframe_id = 0;
  EXPECT_EQ(try_link(unset).code(), StatusCode::kInvalidArgument);

  LinkRecord cross_map = unknown;
  cross_map.to_keyframe_id = ids.keyframe_ids[1];
  status = try_link(cross_map);
  EXPECT_EQ(status.code(), StatusCode::kInvalidArgument);
  EXPECT_NE(status.message().find("belongs to map id"), std::string::npos);

  LinkRecord no_map = unknown;
  no_map.map_id = 555;
  EXPECT_EQ(try_link(no_map).code(), StatusCode::kNotFound);

  LinkRecord bad_kind = cross_map;
  bad_kind.to_keyframe_id = ids.keyframe_ids[0];
  bad_kind.kind = static_cast<LinkKind>(9);
  EXPECT_EQ(try_link(bad_kind).code(), StatusCode::kInvalidArgument);

  LinkRecord nan_info = bad_kind;
  nan_info.kind = LinkKind::kLoop;
  nan_info.information(2, 3) = std::numeric_limits<double>::infinity();
  EXPECT_EQ(try_link(nan_info).code(), StatusCode::kInvalidArgument);

  EXPECT_EQ(Count("links"), 0);
  EXPECT_EQ(Count("frames"), 0);  // every failed batch rolled back its frame too
  EXPECT_EQ(store_->ListLinks(12345).status().code(), StatusCode::kNotFound);
}

// --- pose updates ---

TEST_F(SqliteMapStoreTest, UpdateKeyframePosesMovesKeyframeAndItsFrame) {
  const SessionInfo s = Session("m", "s");
  WriteBatch batch;
  batch.frames = {{s.id, FramePose(0, true)}, {s.id, FramePose(1, false)}};
  batch.keyframes.push_back(Keyframe(s.id, 0));
  const int64_t kf = Write(batch).keyframe_ids.at(0);
  const Eigen::Isometry3d optimised = PoseAt(-3.0, 0.7);
  ASSERT_OK(store_->UpdateKeyframePoses({{kf, optimised}}));
  ExpectPoseNear(store_->GetKeyframe(kf)->T_world_camera, optimised);
  auto trajectory = store_->GetTrajectory(s.id, false);
  ASSERT_OK(trajectory.status());
  ExpectPoseNear((*trajectory)[0].T_world_camera, optimised);
  ExpectPoseNear((*trajectory)[1].T_world_camera, FramePose(1).T_world_camera);  // untouched
}

TEST_F(SqliteMapStoreTest, UpdateKeyframePosesIsAllOrNothing) {
  const SessionInfo s = Session("m", "s");
  WriteBatch batch;
  batch.keyframes.push_back(Keyframe(s.id, 0));
  const int64_t kf = Write(batch).keyframe_ids.at(0);
  Status status = store_->UpdateKeyframePoses({{kf, PoseAt(9.0)}, {kf + 100, PoseAt(1.0)}});
  EXPECT_EQ(status.code(), StatusCode::kNotFound);
  ExpectPoseNear(store_->GetKeyframe(kf)->T_world_camera, Keyframe(s.id, 0).T_world_camera);
  EXPECT_OK(store_->UpdateKeyframePoses({}));
}

TEST_F(SqliteMapStoreTest, PoseUpdatesMoveFramesAndKeyframesInTheBatch) {
  const SessionInfo s = Session("m", "s");
  WriteBatch batch;
  batch.frames = {{s.id, FramePose(0, true)}, {s.id, FramePose(1, false)}};
  batch.keyframes.push_back(Keyframe(s.id, 0));
  // Updates apply after the rows of the same batch: a frame written and moved at once.
  batch.pose_updates.push_back({s.id, 1, PoseAt(5.0, 0.3)});
  const int64_t kf = Write(batch).keyframe_ids.at(0);
  WriteBatch update;
  update.pose_updates.push_back({s.id, 0, PoseAt(-2.0, 0.1)});
  Write(update);
  ExpectPoseNear(store_->GetKeyframe(kf)->T_world_camera, PoseAt(-2.0, 0.1));
  auto trajectory = store_->GetTrajectory(s.id, false);
  ASSERT_OK(trajectory.status());
  ExpectPoseNear((*trajectory)[0].T_world_camera, PoseAt(-2.0, 0.1));
  ExpectPoseNear((*trajectory)[1].T_world_camera, PoseAt(5.0, 0.3));
}

TEST_F(SqliteMapStoreTest, LostFramesAreFlagged) {
  const SessionInfo s = Session("m", "s");
  WriteBatch batch;
  TrajectoryPose lost = FramePose(1);
  lost.lost = true;
  batch.frames = {{s.id, FramePose(0)}, {s.id, lost}};
  Write(batch);
  auto trajectory = store_->GetTrajectory(s.id, false);
  ASSERT_OK(trajectory.status());
  EXPECT_FALSE((*trajectory)[0].lost);
  EXPECT_TRUE((*trajectory)[1].lost);
}

TEST_F(SqliteMapStoreTest, PoseUpdateOfAMissingFrameFailsTheBatch) {
  const SessionInfo s = Session("m", "s");
  WriteBatch batch;
  batch.frames = {{s.id, FramePose(0)}};
  batch.pose_updates.push_back({s.id, 7, PoseAt(1.0)});
  auto result = store_->Write(batch);
  EXPECT_EQ(result.status().code(), StatusCode::kNotFound) << result.status().ToString();
  EXPECT_NE(result.status().message().find("seq 7"), std::string::npos);
  EXPECT_EQ(Count("frames"), 0);  // all or nothing
}

// --- keyframe features ---

TEST_F(SqliteMapStoreTest, KeyframeFeaturesRoundTripAndAreOptional) {
  const SessionInfo s = Session("m", "s");
  WriteBatch batch;
  KeyframeRecord with = Keyframe(s.id, 0);
  with.features_format = "semmap-features-v1";
  with.features = std::string("\0\1binary\xff\0", 10);
  batch.keyframes = {with, Keyframe(s.id, 1)};
  const WriteResult written = Write(batch);
  auto read = store_->GetKeyframe(written.keyframe_ids.at(0));
  ASSERT_OK(read.status());
  EXPECT_EQ(read->features_format, "semmap-features-v1");
  EXPECT_EQ(read->features, with.features);
  auto without = store_->GetKeyframe(written.keyframe_ids.at(1));
  ASSERT_OK(without.status());
  EXPECT_TRUE(without->features.empty());
  auto listed = store_->ListKeyframes(s.id, /*with_images=*/true);
  ASSERT_OK(listed.status());
  EXPECT_EQ((*listed)[0].features, with.features);
  auto bare = store_->ListKeyframes(s.id, /*with_images=*/false);
  ASSERT_OK(bare.status());
  EXPECT_TRUE((*bare)[0].features.empty());
  auto features_only = store_->ListKeyframeFeatures(s.id);
  ASSERT_OK(features_only.status());
  ASSERT_EQ(features_only->size(), 2u);
  EXPECT_EQ((*features_only)[0].features, with.features);
  EXPECT_TRUE((*features_only)[0].colour.bytes.empty());
  EXPECT_TRUE((*features_only)[1].features.empty());
  auto one = store_->GetKeyframeFeatures(s.id, 0);
  ASSERT_OK(one.status());
  EXPECT_EQ(one->seq, 0);
  EXPECT_EQ(one->features_format, "semmap-features-v1");
  EXPECT_EQ(one->features, with.features);
  EXPECT_TRUE(one->colour.bytes.empty());
  auto one_without = store_->GetKeyframeFeatures(s.id, 1);
  ASSERT_OK(one_without.status());
  EXPECT_TRUE(one_without->features.empty());
  EXPECT_EQ(store_->GetKeyframeFeatures(s.id, 2).status().code(), StatusCode::kNotFound);
  EXPECT_EQ(store_->GetKeyframeFeatures(s.id + 1, 0).status().code(), StatusCode::kNotFound);
}

TEST_F(SqliteMapStoreTest, FeaturesWithoutFormatAreRejected) {
  const SessionInfo s = Session("m", "s");
  WriteBatch batch;
  KeyframeRecord kf = Keyframe(s.id, 0);
  kf.features = "xyz";
  batch.keyframes = {kf};
  EXPECT_EQ(store_->Write(batch).status().code(), StatusCode::kInvalidArgument);
}

TEST_F(SqliteMapStoreTest, CorruptedFeaturesAreDataLoss) {
  const SessionInfo s = Session("m", "s");
  WriteBatch batch;
  KeyframeRecord kf = Keyframe(s.id, 0);
  kf.features_format = "semmap-features-v1";
  kf.features = std::string(64, 'a');
  batch.keyframes = {kf};
  const int64_t id = Write(batch).keyframe_ids.at(0);
  ASSERT_OK(store_->connection().Exec(
      "UPDATE keyframe_features SET data = zeroblob(64) WHERE keyframe_id = " +
      std::to_string(id)));
  auto read = store_->GetKeyframe(id);
  EXPECT_EQ(read.status().code(), StatusCode::kDataLoss) << read.status().ToString();
  EXPECT_EQ(store_->GetKeyframeFeatures(s.id, 0).status().code(), StatusCode::kDataLoss);
}

// --- map points ---

MapPointObservationRecord Seen(int64_t session_id, int64_t seq, int32_t keypoint) {
  MapPointObservationRecord o;
  o.session_id = session_id;
  o.seq = seq;
  o.keypoint = keypoint;
  return o;
}

MapPointRecord Point(int64_t point_id, int64_t session_id,
                     std::vector<MapPointObservationRecord> observations) {
  MapPointRecord p;
  p.point_id = point_id;
  p.session_id = session_id;
  // Values without a short decimal form: they must come back bit for bit.
  const double id = static_cast<double>(point_id);
  p.position_world = Eigen::Vector3d(id / 3.0, -0.1 * id, 1e-300 + id);
  p.observations = std::move(observations);
  return p;
}

using ObservationKey = std::tuple<int64_t, int64_t, int32_t>;

std::vector<ObservationKey> Keys(const MapPointRecord& point) {
  std::vector<ObservationKey> keys;
  keys.reserve(point.observations.size());
  for (const MapPointObservationRecord& o : point.observations) {
    keys.emplace_back(o.session_id, o.seq, o.keypoint);
  }
  return keys;
}

std::vector<int64_t> PointIds(const std::vector<MapPointRecord>& points) {
  std::vector<int64_t> ids;
  ids.reserve(points.size());
  for (const MapPointRecord& p : points) ids.push_back(p.point_id);
  return ids;
}

void ExpectSamePoint(const MapPointRecord& got, const MapPointRecord& want) {
  EXPECT_EQ(got.point_id, want.point_id);
  EXPECT_EQ(got.session_id, want.session_id);
  EXPECT_EQ(got.position_world, want.position_world) << "point id " << want.point_id;
  EXPECT_EQ(Keys(got), Keys(want)) << "point id " << want.point_id;
}

class MapPointStoreTest : public SqliteMapStoreTest {
 protected:
  void Keyframes(int64_t session_id, std::initializer_list<int64_t> seqs) {
    WriteBatch batch;
    for (int64_t seq : seqs) batch.keyframes.push_back(Keyframe(session_id, seq));
    Write(batch);
  }
  void WritePoints(int64_t map_id, std::vector<MapPointRecord> points) {
    WriteBatch batch;
    batch.map_points.emplace_back(map_id, std::move(points));
    Write(batch);
  }
  std::vector<MapPointRecord> Points(int64_t map_id) {
    auto points = store_->ListMapPoints(map_id);
    EXPECT_TRUE(points.ok()) << points.status().ToString();
    return points.ok() ? *points : std::vector<MapPointRecord>{};
  }
};

TEST_F(MapPointStoreTest, RoundTripExactlyInPointIdOrder) {
  const SessionInfo s = Session("m", "s");
  Keyframes(s.id, {0, 1, 2});
  const std::vector<MapPointRecord> written = {
      Point(7, s.id, {Seen(s.id, 0, 5), Seen(s.id, 2, 0)}),
      Point(3, s.id, {Seen(s.id, 1, std::numeric_limits<int32_t>::max())}),
  };
  WritePoints(s.map_id, written);
  for (int pass = 0; pass < 2; ++pass) {  // then again from disk
    const std::vector<MapPointRecord> read = Points(s.map_id);
    ASSERT_EQ(PointIds(read), (std::vector<int64_t>{3, 7}));
    ExpectSamePoint(read[0], written[1]);
    ExpectSamePoint(read[1], written[0]);
    Reopen();
  }
  EXPECT_TRUE(Points(Map("empty").id).empty());
  EXPECT_EQ(store_->ListMapPoints(999).status().code(), StatusCode::kNotFound);
  EXPECT_OK(store_->IntegrityCheck());
}

TEST_F(MapPointStoreTest, SecondWriteReplacesTheMapsPoints) {
  const SessionInfo s = Session("m", "s");
  Keyframes(s.id, {0});
  WritePoints(s.map_id, {Point(1, s.id, {Seen(s.id, 0, 1)}), Point(2, s.id, {Seen(s.id, 0, 2)}),
                         Point(3, s.id, {Seen(s.id, 0, 3)})});
  const MapPointRecord moved = Point(2, s.id, {Seen(s.id, 0, 9)});
  WritePoints(s.map_id, {moved, Point(4, s.id, {Seen(s.id, 0, 4)})});
  const std::vector<MapPointRecord> read = Points(s.map_id);
  ASSERT_EQ(PointIds(read), (std::vector<int64_t>{2, 4}));
  ExpectSamePoint(read[0], moved);
  EXPECT_EQ(Count("map_points"), 2);
  WritePoints(s.map_id, {});  // an empty list clears the map
  EXPECT_EQ(Count("map_points"), 0);
}

TEST_F(MapPointStoreTest, MapsKeepTheirOwnPoints) {
  const SessionInfo a = Session("a", "s");
  const SessionInfo b = Session("b", "s");
  Keyframes(a.id, {0});
  Keyframes(b.id, {0});
  WriteBatch batch;  // both maps in one batch, with the same point id
  batch.map_points.emplace_back(a.map_id, std::vector{Point(1, a.id, {Seen(a.id, 0, 1)})});
  batch.map_points.emplace_back(b.map_id, std::vector{Point(1, b.id, {Seen(b.id, 0, 2)})});
  Write(batch);
  WritePoints(a.map_id, {Point(2, a.id, {Seen(a.id, 0, 3)})});
  EXPECT_EQ(PointIds(Points(a.map_id)), (std::vector<int64_t>{2}));
  const std::vector<MapPointRecord> of_b = Points(b.map_id);
  ASSERT_EQ(of_b.size(), 1u);
  ExpectSamePoint(of_b[0], Point(1, b.id, {Seen(b.id, 0, 2)}));
}

TEST_F(MapPointStoreTest, ObservationsOfUnstoredKeyframesAreLeftOut) {
  const SessionInfo s = Session("m", "s");
  const SessionInfo elsewhere = Session("other", "s");
  Keyframes(s.id, {0, 1});
  Keyframes(elsewhere.id, {0});
  WritePoints(s.map_id, {
                            Point(1, s.id, {Seen(s.id, 0, 1), Seen(s.id, 5, 2)}),
                            Point(2, s.id, {Seen(s.id, 9, 0), Seen(999, 0, 0)}),
                            Point(3, s.id, {Seen(elsewhere.id, 0, 0)}),  // another map's keyframe
                            Point(4, s.id, {}),
                        });
  EXPECT_EQ(Count("map_points"), 4);  // stored as given, filtered when read
  std::vector<MapPointRecord> read = Points(s.map_id);
  ASSERT_EQ(PointIds(read), (std::vector<int64_t>{1}));
  EXPECT_EQ(Keys(read[0]), (std::vector<ObservationKey>{{s.id, 0, 1}}));
  Keyframes(s.id, {5});  // a keyframe stored later brings its observation back
  read = Points(s.map_id);
  ASSERT_EQ(read.size(), 1u);
  EXPECT_EQ(Keys(read[0]), (std::vector<ObservationKey>{{s.id, 0, 1}, {s.id, 5, 2}}));
}

TEST_F(MapPointStoreTest, RemovingASessionTakesItsObservations) {
  const SessionInfo a = Session("m", "a");
  const SessionInfo b = Session("m", "b");
  Keyframes(a.id, {0, 1});
  Keyframes(b.id, {0});
  WritePoints(a.map_id, {Point(1, a.id, {Seen(a.id, 0, 3), Seen(b.id, 0, 4)}),
                         Point(2, a.id, {Seen(a.id, 1, 0)}), Point(3, b.id, {Seen(b.id, 0, 1)})});
  ASSERT_OK(store_->RemoveSession(a.id).status());
  const std::vector<MapPointRecord> read = Points(a.map_id);
  ASSERT_EQ(PointIds(read), (std::vector<int64_t>{1, 3}));
  EXPECT_EQ(read[0].session_id, a.id);  // the point stays, created by a session now gone
  EXPECT_EQ(Keys(read[0]), (std::vector<ObservationKey>{{b.id, 0, 4}}));
  EXPECT_EQ(Count("map_points"), 2);  // the point seen only by a is deleted, not just hidden
  EXPECT_OK(store_->IntegrityCheck());
}

// SQLite hands the largest session id out again once that session is removed: its keyframe
// keys come back, and must not revive the removed session's observations.
TEST_F(MapPointStoreTest, AReusedSessionIdDoesNotInheritObservations) {
  const SessionInfo a = Session("m", "a");
  const SessionInfo b = Session("m", "b");
  Keyframes(a.id, {0});
  Keyframes(b.id, {0});
  WritePoints(a.map_id, {Point(1, a.id, {Seen(a.id, 0, 0), Seen(b.id, 0, 7)}),
                         Point(2, b.id, {Seen(b.id, 0, 1)})});
  ASSERT_OK(store_->RemoveSession(b.id).status());
  const SessionInfo c = Session("m", "c");
  ASSERT_EQ(c.id, b.id) << "the test needs the id to be reused";
  Keyframes(c.id, {0});
  const std::vector<MapPointRecord> read = Points(a.map_id);
  ASSERT_EQ(PointIds(read), (std::vector<int64_t>{1}));
  EXPECT_EQ(Keys(read[0]), (std::vector<ObservationKey>{{a.id, 0, 0}}));
}

TEST_F(MapPointStoreTest, RemovingTheMapTakesItsPoints) {
  const SessionInfo s = Session("m", "s");
  const SessionInfo kept = Session("kept", "s");
  Keyframes(s.id, {0});
  Keyframes(kept.id, {0});
  WritePoints(s.map_id, {Point(1, s.id, {Seen(s.id, 0, 0)}), Point(2, s.id, {Seen(s.id, 0, 1)})});
  WritePoints(kept.map_id, {Point(1, kept.id, {Seen(kept.id, 0, 0)})});
  ASSERT_OK(store_->RemoveMap(s.map_id).status());
  EXPECT_EQ(Count("map_points WHERE map_id = " + std::to_string(s.map_id)), 0);
  EXPECT_EQ(PointIds(Points(kept.map_id)), (std::vector<int64_t>{1}));
  EXPECT_OK(store_->IntegrityCheck());
}

TEST_F(MapPointStoreTest, InvalidPointsFailTheWholeBatch) {
  const SessionInfo s = Session("m", "s");
  Keyframes(s.id, {0});
  WritePoints(s.map_id, {Point(1, s.id, {Seen(s.id, 0, 0)})});
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const double inf = std::numeric_limits<double>::infinity();
  struct Case {
    const char* name;
    MapPointRecord bad;
    StatusCode code;
    const char* detail;
  };
  std::vector<Case> cases = {
      {"nan", Point(5, s.id, {Seen(s.id, 0, 0)}), StatusCode::kInvalidArgument, "not finite"},
      {"inf", Point(5, s.id, {Seen(s.id, 0, 0)}), StatusCode::kInvalidArgument, "not finite"},
      {"negative keypoint", Point(5, s.id, {Seen(s.id, 0, -1)}), StatusCode::kInvalidArgument,
       "keypoint -1"},
      {"repeated id", Point(2, s.id, {Seen(s.id, 0, 0)}), StatusCode::kInvalidArgument, "twice"},
  };
  cases[0].bad.position_world.y() = nan;
  cases[1].bad.position_world.z() = -inf;
  for (const Case& c : cases) {
    SCOPED_TRACE(c.name);
    WriteBatch batch;
    batch.keyframes.push_back(Keyframe(s.id, 1));
    batch.map_points.emplace_back(
        s.map_id, std::vector{Point(2, s.id, {Seen(s.id, 0, 1)}), c.bad, Point(6, s.id, {})});
    auto result = store_->Write(batch);
    EXPECT_EQ(result.status().code(), c.code) << result.status().ToString();
    EXPECT_NE(result.status().message().find("map point id " + std::to_string(c.bad.point_id)),
              std::string::npos)
        << result.status().message();
    EXPECT_NE(result.status().message().find(c.detail), std::string::npos)
        << result.status().message();
    // Nothing of the batch is left: no keyframe, the old points untouched.
    EXPECT_EQ(Count("keyframes"), 1);
    EXPECT_EQ(PointIds(Points(s.map_id)), (std::vector<int64_t>{1}));
  }
  WriteBatch unknown_map;
  unknown_map.map_points.emplace_back(777, std::vector<MapPointRecord>{});
  EXPECT_EQ(store_->Write(unknown_map).status().code(), StatusCode::kNotFound);
}

TEST_F(MapPointStoreTest, CorruptObservationsAreDataLoss) {
  const SessionInfo s = Session("m", "s");
  const SessionInfo other = Session("m", "other");
  Keyframes(s.id, {0});
  // One observation: the count 1, then 20 bytes.
  const std::string valid = *sqlite::EncodeMapPointObservations({Seen(s.id, 0, 1)});
  ASSERT_EQ(valid.size(), 24u);
  const std::pair<const char*, std::string> corruptions[] = {
      {"empty", ""},
      {"shorter than the count", valid.substr(0, 3)},
      {"truncated", valid.substr(0, 20)},
      {"count too large", '\x02' + valid.substr(1)},
      {"count too small", '\x00' + valid.substr(1)},
      {"huge count", std::string(4, '\xff') + valid.substr(4)},
      {"trailing byte", valid + '\x00'},
      {"negative keypoint", valid.substr(0, 20) + std::string(4, '\xff')},
  };
  for (const auto& [name, bytes] : corruptions) {
    SCOPED_TRACE(name);
    WritePoints(s.map_id, {Point(1, s.id, {Seen(s.id, 0, 0)}), Point(7, s.id, {Seen(s.id, 0, 1)})});
    {
      auto stmt = store_->connection().Prepare(
          "UPDATE map_points SET observations = ?1 WHERE point_id = 7");
      ASSERT_OK(stmt.status());
      ASSERT_OK((*stmt)->BindBlob(1, bytes));
      ASSERT_OK((*stmt)->Run());
    }
    auto read = store_->ListMapPoints(s.map_id);
    ASSERT_EQ(read.status().code(), StatusCode::kDataLoss) << read.status().ToString();
    EXPECT_NE(read.status().message().find("map point id 7 of map id " + std::to_string(s.map_id)),
              std::string::npos)
        << read.status().message();
  }
  // Removing a session leaves a corrupt row as it is: still reported, not silently dropped.
  ASSERT_OK(store_->RemoveSession(other.id).status());
  EXPECT_EQ(store_->ListMapPoints(s.map_id).status().code(), StatusCode::kDataLoss);
}

TEST(WriteBatchAppendTest, LaterMapPointsWin) {
  WriteBatch merged;
  WriteBatch a;
  a.map_points.emplace_back(1, std::vector<MapPointRecord>(3));
  a.map_points.emplace_back(2, std::vector<MapPointRecord>(1));
  WriteBatch b;
  b.map_points.emplace_back(1, std::vector<MapPointRecord>(5));
  merged.Append(std::move(a));
  merged.Append(std::move(b));
  EXPECT_TRUE(b.map_points.empty());  // NOLINT(bugprone-use-after-move): part of the contract
  ASSERT_EQ(merged.map_points.size(), 2u);
  EXPECT_EQ(merged.map_points[0].first, 1);
  EXPECT_EQ(merged.map_points[0].second.size(), 5u);
  EXPECT_EQ(merged.map_points[1].first, 2);
  EXPECT_EQ(merged.map_points[1].second.size(), 1u);
  WriteBatch only_points;
  only_points.map_points.emplace_back(4, std::vector<MapPointRecord>{});
  EXPECT_FALSE(only_points.empty());  // an empty list still clears its map
}

// --- blobs ---

TEST_F(SqliteMapStoreTest, BlobRoundTripAndReplace) {
  const int64_t map = Map("m").id;
  WriteBatch batch;
  batch.blobs.push_back({map, "octomap.ot", std::string("tree\0data", 9), 123});
  batch.blobs.push_back({map, "empty", "", 0});
  Write(batch);
  auto blob = store_->GetBlob(map, "octomap.ot");
  ASSERT_OK(blob.status());
  EXPECT_EQ(blob->map_id, map);
  EXPECT_EQ(blob->kind, "octomap.ot");
  EXPECT_EQ(blob->data, std::string("tree\0data", 9));
  EXPECT_EQ(blob->updated_unix_ns, 123);
  auto empty = store_->GetBlob(map, "empty");
  ASSERT_OK(empty.status());
  EXPECT_EQ(empty->data, "");
  EXPECT_GT(empty->updated_unix_ns, 0);  // defaults to now

  WriteBatch replace;
  replace.blobs.push_back({map, "octomap.ot", std::string(100000, 'z'), 456});
  Write(replace);
  EXPECT_EQ(store_->GetBlob(map, "octomap.ot")->data, std::string(100000, 'z'));
  EXPECT_EQ(Count("blobs"), 2);

  EXPECT_EQ(store_->GetBlob(map, "nope").status().code(), StatusCode::kNotFound);
  WriteBatch unknown_map;
  unknown_map.blobs.push_back({777, "x", "y", 0});
  EXPECT_EQ(store_->Write(unknown_map).status().code(), StatusCode::kNotFound);
  WriteBatch no_kind;
  no_kind.blobs.push_back({map, "", "y", 0});
  EXPECT_EQ(store_->Write(no_kind).status().code(), StatusCode::kInvalidArgument);
}

class BlobCorruptionTest : public SqliteMapStoreTest {
 protected:
  void SetUp() override {
    SqliteMapStoreTest::SetUp();
    map_ = Map("m").id;
    WriteBatch batch;
    batch.blobs.push_back({map_, "octomap.ot", "0123456789", 0});
    Write(batch);
  }
  Status Corrupt(const std::string& set) {
    return store_->connection().Exec("UPDATE blobs SET " + set + " WHERE kind = 'octomap.ot'");
  }
  void ExpectDataLoss(const std::string& detail) {
    auto blob = store_->GetBlob(map_, "octomap.ot");
    ASSERT_FALSE(blob.ok());
    EXPECT_EQ(blob.status().code(), StatusCode::kDataLoss);
    EXPECT_NE(blob.status().message().find("map blob 'octomap.ot'"), std::string::npos)
        << blob.status().message();
    EXPECT_NE(blob.status().message().find(detail), std::string::npos) << blob.status().message();
  }
  int64_t map_ = 0;
};

TEST_F(BlobCorruptionTest, AlteredBytesOfTheSameLength) {
  ASSERT_OK(Corrupt("data = CAST('0123456780' AS BLOB)"));
  ExpectDataLoss("sha256");
}

TEST_F(BlobCorruptionTest, TruncatedData) {
  ASSERT_OK(Corrupt("data = substr(data, 1, 4)"));
  ExpectDataLoss("stored length 10, read 4");
}

TEST_F(BlobCorruptionTest, WrongStoredChecksum) {
  ASSERT_OK(Corrupt("sha256 = zeroblob(32)"));
  ExpectDataLoss("sha256");
}

TEST_F(BlobCorruptionTest, WrongStoredLength) {
  ASSERT_OK(Corrupt("length = 11"));
  ExpectDataLoss("stored length 11");
}

// --- durability, concurrency, maintenance ---

TEST_F(SqliteMapStoreTest, EverythingPersistsAcrossReopen) {
  const SessionInfo s = Session("m", "s");
  WriteBatch batch;
  batch.frames = {{s.id, FramePose(0, true)}, {s.id, FramePose(1)}};
  batch.keyframes.push_back(Keyframe(s.id, 0));
  batch.keyframes.push_back(Keyframe(s.id, 1));
  LinkRecord link;
  link.map_id = s.map_id;
  link.from_session_id = s.id;
  link.from_seq = 0;
  link.to_session_id = s.id;
  link.to_seq = 1;
  batch.links.push_back(link);
  batch.blobs.push_back({s.map_id, "cloud.pcd", "points", 5});
  const WriteResult written = Write(batch);
  ASSERT_OK(store_->EndSession(s.id, 77, SessionEndReason::kCompleted, ""));
  ASSERT_OK(store_->Checkpoint());

  Reopen();
  auto session = store_->GetSession("m", "s");
  ASSERT_OK(session.status());
  EXPECT_EQ(session->id, s.id);
  EXPECT_EQ(session->ended_unix_ns, 77);
  EXPECT_EQ(session->frame_count, 2);
  EXPECT_EQ(session->keyframe_count, 2);
  EXPECT_EQ(store_->GetTrajectory(s.id, false)->size(), 2u);
  EXPECT_EQ(store_->GetKeyframe(written.keyframe_ids[1])->colour.bytes,
            Keyframe(s.id, 1).colour.bytes);
  EXPECT_EQ(store_->ListLinks(s.map_id)->size(), 1u);
  EXPECT_EQ(store_->GetBlob(s.map_id, "cloud.pcd")->data, "points");
  EXPECT_OK(store_->IntegrityCheck());
}

TEST_F(SqliteMapStoreTest, ReaderSeesCommittedDataWhileTheWriterWorks) {
  const SessionInfo s = Session("m", "s");
  WriteBatch committed;
  committed.frames.emplace_back(s.id, FramePose(0));
  Write(committed);

  SqliteOptions quick;
  quick.busy_timeout_ms = 10;  // a reader that had to wait would fail fast
  auto reader = SqliteMapStore::Open(path(), quick);
  ASSERT_OK(reader.status());
  {
    // The writer holds an open write transaction with uncommitted rows.
    auto txn = sqlite::Transaction::Begin(store_->connection());
    ASSERT_OK(txn.status());
    ASSERT_OK(store_->connection().Exec("INSERT INTO frames VALUES (" + std::to_string(s.id) +
                                        ", 1, 0, 0, 0, 0, 0, 0, 0, 1, 0, 0)"));
    auto during = (*reader)->GetTrajectory(s.id, false);
    ASSERT_OK(during.status());     // not blocked by the writer
    EXPECT_EQ(during->size(), 1u);  // and only committed rows
    EXPECT_EQ((*reader)->GetSession("m", "s")->frame_count, 1);
    ASSERT_OK(txn->Commit());
  }
  EXPECT_EQ((*reader)->GetTrajectory(s.id, false)->size(), 2u);
  // And the other way round: a write through the store while the reader is connected.
  WriteBatch more;
  more.frames.emplace_back(s.id, FramePose(2));
  Write(more);
  EXPECT_EQ((*reader)->GetSession("m", "s")->frame_count, 3);
}

TEST_F(SqliteMapStoreTest, IntegrityCheckReportsDanglingReferences) {
  Session("m", "s");
  EXPECT_OK(store_->IntegrityCheck());
  ASSERT_OK(store_->connection().Exec("PRAGMA foreign_keys = OFF"));
  ASSERT_OK(store_->connection().Exec(
      "INSERT INTO frames VALUES (4242, 0, 0, 0, 0, 0, 0, 0, 0, 1, 0, 0)"));
  ASSERT_OK(store_->connection().Exec("PRAGMA foreign_keys = ON"));
  Status status = store_->IntegrityCheck();
  EXPECT_EQ(status.code(), StatusCode::kDataLoss);
  EXPECT_NE(status.message().find("of frames references a missing row of sessions"),
            std::string::npos)
      << status.message();
}

TEST_F(SqliteMapStoreTest, CheckpointEmptiesTheWal) {
  const SessionInfo s = Session("m", "s");
  WriteBatch batch;
  for (int64_t seq = 0; seq < 100; ++seq) batch.frames.emplace_back(s.id, FramePose(seq));
  Write(batch);
  const std::string wal = path() + "-wal";
  ASSERT_TRUE(std::filesystem::exists(wal));
  EXPECT_GT(std::filesystem::file_size(wal), 0u);
  ASSERT_OK(store_->Checkpoint());
  EXPECT_EQ(std::filesystem::file_size(wal), 0u);
  EXPECT_EQ(store_->GetTrajectory(s.id, false)->size(), 100u);
}

}  // namespace
}  // namespace semmap
