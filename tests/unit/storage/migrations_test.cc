// Schema migrations: applied once, idempotent on reopen, newer schemas refused.
#include "storage/sqlite/migrations.h"

#include <gtest/gtest.h>

#include <vector>

#include "storage/sqlite/sqlite_map_store.h"
#include "tests/unit/storage/storage_test_util.h"

namespace semmap::sqlite {
namespace {

using storage_test::TempDir;

std::unique_ptr<Connection> Open(const std::string& path) {
  auto db = Connection::Open(path, {});
  EXPECT_TRUE(db.ok()) << db.status().ToString();
  return db.ok() ? std::move(db).value() : nullptr;
}

// Step 2 counts how often it ran: an INSERT that would repeat if the step ran twice.
constexpr Migration kTwoSteps[] = {
    {1, "log table", "CREATE TABLE log (what TEXT NOT NULL)"},
    {2, "first entry", "INSERT INTO log VALUES ('step 2')"},
};

TEST(MigrationsTest, AppliesEveryStepOnceAndIsIdempotent) {
  TempDir dir;
  {
    auto db = Open(dir.File("m.db"));
    ASSERT_NE(db, nullptr);
    EXPECT_EQ(*ReadSchemaVersion(*db), 0);
    ASSERT_OK(ApplyMigrations(*db, kTwoSteps));
    EXPECT_EQ(*ReadSchemaVersion(*db), 2);
    ASSERT_OK(ApplyMigrations(*db, kTwoSteps));  // same connection: nothing to do
    EXPECT_EQ(*db->QueryInt64("SELECT COUNT(*) FROM log"), 1);
  }
  auto reopened = Open(dir.File("m.db"));
  ASSERT_NE(reopened, nullptr);
  ASSERT_OK(ApplyMigrations(*reopened, kTwoSteps));
  EXPECT_EQ(*reopened->QueryInt64("SELECT COUNT(*) FROM log"), 1);
  EXPECT_EQ(*ReadSchemaVersion(*reopened), 2);
}

TEST(MigrationsTest, OnlyNewStepsRunOnUpgrade) {
  TempDir dir;
  auto db = Open(dir.File("m.db"));
  ASSERT_NE(db, nullptr);
  ASSERT_OK(ApplyMigrations(*db, std::span(kTwoSteps).first(1)));
  EXPECT_EQ(*ReadSchemaVersion(*db), 1);
  EXPECT_EQ(*db->QueryInt64("SELECT COUNT(*) FROM log"), 0);
  ASSERT_OK(ApplyMigrations(*db, kTwoSteps));
  EXPECT_EQ(*ReadSchemaVersion(*db), 2);
  EXPECT_EQ(*db->QueryInt64("SELECT COUNT(*) FROM log"), 1);
}

TEST(MigrationsTest, FailingStepLeavesTheDatabaseUntouched) {
  TempDir dir;
  auto db = Open(dir.File("m.db"));
  ASSERT_NE(db, nullptr);
  constexpr Migration kBroken[] = {
      {1, "log table", "CREATE TABLE log (what TEXT NOT NULL)"},
      {2, "broken", "INSERT INTO nowhere VALUES (1)"},
  };
  Status status = ApplyMigrations(*db, kBroken);
  ASSERT_FALSE(status.ok());
  EXPECT_NE(status.message().find("schema migration 2 (broken)"), std::string::npos)
      << status.message();
  EXPECT_NE(status.message().find("no such table: nowhere"), std::string::npos);
  // Step 1 ran in the same transaction and was rolled back with it.
  EXPECT_EQ(*ReadSchemaVersion(*db), 0);
  EXPECT_EQ(*db->QueryInt64("SELECT COUNT(*) FROM sqlite_schema WHERE name = 'log'"), 0);
  EXPECT_FALSE(db->in_transaction());
}

TEST(MigrationsTest, NewerSchemaIsRefused) {
  TempDir dir;
  auto db = Open(dir.File("m.db"));
  ASSERT_NE(db, nullptr);
  ASSERT_OK(db->Exec("PRAGMA user_version = 7"));
  Status status = ApplyMigrations(*db, kTwoSteps);
  EXPECT_EQ(status.code(), StatusCode::kFailedPrecondition);
  EXPECT_EQ(status.message(),
            "database schema version 7 is newer than this semmapd supports (2); upgrade semmapd");
  EXPECT_EQ(*ReadSchemaVersion(*db), 7);  // left alone
}

TEST(MigrationsTest, StepsMustBeNumberedWithoutGaps) {
  TempDir dir;
  auto db = Open(dir.File("m.db"));
  ASSERT_NE(db, nullptr);
  constexpr Migration kGap[] = {{1, "a", "SELECT 1"}, {3, "c", "SELECT 1"}};
  EXPECT_EQ(ApplyMigrations(*db, kGap).code(), StatusCode::kInternal);
  EXPECT_EQ(*ReadSchemaVersion(*db), 0);
}

TEST(MigrationsTest, ShippedSchemaIsNumberedAndCurrent) {
  const auto steps = SchemaMigrations();
  ASSERT_FALSE(steps.empty());
  for (size_t i = 0; i < steps.size(); ++i) EXPECT_EQ(steps[i].version, static_cast<int>(i) + 1);
  EXPECT_EQ(LatestSchemaVersion(), steps.back().version);
}

TEST(MigrationsTest, StoreOpenMigratesOnceAndRefusesNewerSchema) {
  TempDir dir;
  const std::string path = dir.File("semmap.db");
  {
    auto store = SqliteMapStore::Open(path, {});
    ASSERT_OK(store.status());
    EXPECT_EQ(*ReadSchemaVersion((*store)->connection()), LatestSchemaVersion());
    ASSERT_OK((*store)->GetOrCreateMap("kept").status());
  }
  {
    auto store = SqliteMapStore::Open(path, {});  // reopen: no step runs again
    ASSERT_OK(store.status());
    EXPECT_EQ((*store)->ListMaps()->size(), 1u);
    ASSERT_OK((*store)->connection().Exec("PRAGMA user_version = " +
                                          std::to_string(LatestSchemaVersion() + 1)));
  }
  auto refused = SqliteMapStore::Open(path, {});
  ASSERT_FALSE(refused.ok());
  EXPECT_EQ(refused.status().code(), StatusCode::kFailedPrecondition);
  const std::string expected = "database schema version " +
                               std::to_string(LatestSchemaVersion() + 1) +
                               " is newer than this semmapd supports (" +
                               std::to_string(LatestSchemaVersion()) + "); upgrade semmapd";
  EXPECT_NE(refused.status().message().find(expected), std::string::npos)
      << refused.status().message();
  EXPECT_NE(refused.status().message().find(path), std::string::npos);
}

TEST(MigrationsTest, Version2DatabaseUpgradesToObjectsKeepingItsData) {
  TempDir dir;
  const std::string path = dir.File("semmap.db");
  {
    // What a v2 semmapd left behind: a map, a session, a keyframe with features.
    auto db = Open(path);
    ASSERT_NE(db, nullptr);
    ASSERT_OK(ApplyMigrations(*db, SchemaMigrations().first(2)));
    ASSERT_OK(db->Exec(
        "INSERT INTO maps VALUES (1, 'lab', 5);"
        "INSERT INTO sessions (id, map_id, name, mode, width, height, fx, fy, cx, cy, k1, k2, p1,"
        " p2, k3, depth_scale, started_ns) VALUES (1, 1, 's', 1, 640, 480, 525, 525, 319.5, 239.5,"
        " 0, 0, 0, 0, 0, 5000, 7);"
        "INSERT INTO keyframes VALUES (1, 1, 4, 99, 1, 2, 3, 0, 0, 0, 1, 'jpeg', x'01', 'png',"
        " x'02', 5000);"
        "INSERT INTO keyframe_features VALUES (1, 'f1', x'616263', 3,"
        " x'ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad');"));
    EXPECT_EQ(*ReadSchemaVersion(*db), 2);
  }
  auto store = SqliteMapStore::Open(path, {});
  ASSERT_OK(store.status());
  SqliteMapStore& s = **store;
  EXPECT_GE(LatestSchemaVersion(), 3);
  EXPECT_EQ(*ReadSchemaVersion(s.connection()), LatestSchemaVersion());
  auto map = s.GetMap("lab");
  ASSERT_OK(map.status());
  EXPECT_EQ(map->keyframe_count, 1);
  auto keyframes = s.ListKeyframeFeatures(1);
  ASSERT_OK(keyframes.status());
  ASSERT_EQ(keyframes->size(), 1u);
  EXPECT_EQ((*keyframes)[0].features, "abc");  // checksum still verifies
  EXPECT_EQ((*keyframes)[0].T_world_camera.translation(), Eigen::Vector3d(1, 2, 3));

  // The new tables work against the old rows.
  ObjectType type;
  type.label = "mug";
  type.map_id = map->id;
  ObjectView view;
  view.image = {"png", "img"};
  view.features_format = "f1";
  view.features = "feat";
  type.views = {view};
  auto created = s.CreateObjectType(type);
  ASSERT_OK(created.status());
  WriteBatch batch;
  ObjectObservation o;
  o.map_id = map->id;
  o.type_id = created->id;
  o.session_id = 1;
  o.seq = 4;
  batch.observations = {o};
  ObjectInstance instance;
  instance.type_id = created->id;
  instance.session_ids = {1};
  batch.instances.emplace_back(map->id, std::vector<ObjectInstance>{instance});
  ASSERT_OK(s.Write(batch).status());
  EXPECT_EQ((*s.ListObjectObservations(map->id))[0].keyframe_id, 1);
  EXPECT_EQ((*s.FindObjectInstances(map->id, "mug"))[0].sessions, (std::vector<std::string>{"s"}));
  EXPECT_OK(s.IntegrityCheck());
}

// A v3 database's sessions, ended or not, read back without a reason (unknown); the next start
// marks the open one crashed.
TEST(MigrationsTest, Version3SessionsUpgradeToEndReasons) {
  TempDir dir;
  const std::string path = dir.File("semmap.db");
  {
    auto db = Open(path);
    ASSERT_NE(db, nullptr);
    ASSERT_OK(ApplyMigrations(*db, SchemaMigrations().first(3)));
    ASSERT_OK(db->Exec(
        "INSERT INTO maps VALUES (1, 'lab', 5);"
        "INSERT INTO sessions (id, map_id, name, mode, width, height, fx, fy, cx, cy, k1, k2, p1,"
        " p2, k3, depth_scale, started_ns, ended_ns) VALUES"
        " (1, 1, 'ended', 1, 640, 480, 525, 525, 319.5, 239.5, 0, 0, 0, 0, 0, 5000, 7, 9),"
        " (2, 1, 'open', 1, 640, 480, 525, 525, 319.5, 239.5, 0, 0, 0, 0, 0, 5000, 8, NULL);"));
  }
  auto store = SqliteMapStore::Open(path, {});
  ASSERT_OK(store.status());
  SqliteMapStore& s = **store;
  EXPECT_GE(LatestSchemaVersion(), 4);
  const SessionInfo ended = *s.GetSession("lab", "ended");
  EXPECT_EQ(ended.end_reason, SessionEndReason::kUnspecified);
  EXPECT_EQ(ended.ended_unix_ns, 9);
  EXPECT_EQ(*s.MarkOpenSessionsCrashed(), 1);
  EXPECT_EQ(s.GetSession("lab", "open")->end_reason, SessionEndReason::kCrashed);
  EXPECT_EQ(s.GetSession("lab", "ended")->end_reason, SessionEndReason::kUnspecified);
  // A stored reason must be a known one.
  EXPECT_FALSE(s.connection().Exec("UPDATE sessions SET end_reason = 7 WHERE id = 1").ok());
  EXPECT_OK(s.IntegrityCheck());
}

// What a v4 or later semmapd left behind: map 'lab', its ended session 's' and one keyframe
// (seq 4 at (1, 2, 3)) with colour and depth bytes 01 and 02.
constexpr char kLabWithOneKeyframeSinceV4[] =
    "INSERT INTO maps VALUES (1, 'lab', 5);"
    "INSERT INTO sessions (id, map_id, name, mode, width, height, fx, fy, cx, cy, k1, k2, p1,"
    " p2, k3, depth_scale, started_ns, ended_ns, end_reason) VALUES (1, 1, 's', 1, 640, 480,"
    " 525, 525, 319.5, 239.5, 0, 0, 0, 0, 0, 5000, 7, 9, 1);"
    "INSERT INTO keyframes VALUES (1, 1, 4, 99, 1, 2, 3, 0, 0, 0, 1, 'jpeg', x'01', 'png',"
    " x'02', 5000);";

// A v4 database keeps its rows, gains the map_points table, and its keyframes can be observed.
TEST(MigrationsTest, Version4DatabaseUpgradesToMapPointsKeepingItsData) {
  TempDir dir;
  const std::string path = dir.File("semmap.db");
  {
    auto db = Open(path);
    ASSERT_NE(db, nullptr);
    ASSERT_OK(ApplyMigrations(*db, SchemaMigrations().first(4)));
    ASSERT_OK(db->Exec(kLabWithOneKeyframeSinceV4));
    EXPECT_EQ(*db->QueryInt64("SELECT COUNT(*) FROM sqlite_schema WHERE name = 'map_points'"), 0);
  }
  auto store = SqliteMapStore::Open(path, {});
  ASSERT_OK(store.status());
  SqliteMapStore& s = **store;
  EXPECT_GE(LatestSchemaVersion(), 5);
  EXPECT_EQ(*ReadSchemaVersion(s.connection()), LatestSchemaVersion());
  const SessionInfo session = *s.GetSession("lab", "s");
  EXPECT_EQ(session.end_reason, SessionEndReason::kCompleted);
  EXPECT_EQ(session.keyframe_count, 1);
  EXPECT_EQ((*s.ListKeyframes(1, false))[0].T_world_camera.translation(), Eigen::Vector3d(1, 2, 3));
  EXPECT_TRUE(s.ListMapPoints(1)->empty());

  MapPointRecord point;
  point.point_id = 11;
  point.session_id = 1;
  point.position_world = Eigen::Vector3d(0.5, -1, 2);
  point.observations = {{1, 4, 17}};
  WriteBatch batch;
  batch.map_points.emplace_back(1, std::vector<MapPointRecord>{point});
  ASSERT_OK(s.Write(batch).status());
  auto points = s.ListMapPoints(1);
  ASSERT_OK(points.status());
  ASSERT_EQ(points->size(), 1u);
  EXPECT_EQ((*points)[0].position_world, point.position_world);
  EXPECT_EQ((*points)[0].observations[0].keypoint, 17);
  // STRICT: a position that is not a number is refused by the table itself.
  EXPECT_FALSE(s.connection().Exec("UPDATE map_points SET x = 'far'").ok());
  ASSERT_OK(s.RemoveMap(1).status());
  EXPECT_EQ(*s.connection().QueryInt64("SELECT COUNT(*) FROM map_points"), 0);
  EXPECT_OK(s.IntegrityCheck());
}

// Version 6 adds keyframes.culled: existing keyframes are kept (not culled) with their
// features; culling one through a WriteBatch marks it and deletes its features only.
TEST(MigrationsTest, Version5KeyframesUpgradeToCullable) {
  TempDir dir;
  const std::string path = dir.File("semmap.db");
  {
    auto db = Open(path);
    ASSERT_NE(db, nullptr);
    ASSERT_OK(ApplyMigrations(*db, SchemaMigrations().first(5)));
    ASSERT_OK(db->Exec(
        std::string(kLabWithOneKeyframeSinceV4) +
        "INSERT INTO keyframes VALUES (2, 1, 8, 99, 1, 2, 3, 0, 0, 0, 1, 'jpeg', x'01', 'png',"
        " x'02', 5000);"));
  }
  auto store = SqliteMapStore::Open(path, {});
  ASSERT_OK(store.status());
  SqliteMapStore& s = **store;
  EXPECT_GE(LatestSchemaVersion(), 6);
  EXPECT_EQ(*ReadSchemaVersion(s.connection()), LatestSchemaVersion());
  // Features (bytes 01 02 and their sha256) written after the upgrade, for both keyframes.
  ASSERT_OK(s.connection().Exec(
      "INSERT INTO keyframe_features VALUES (1, 'f', x'0102', 2,"
      " x'a12871fee210fb8619291eaea194581cbd2531e4b23759d225f6806923f63222');"
      "INSERT INTO keyframe_features VALUES (2, 'f', x'0102', 2,"
      " x'a12871fee210fb8619291eaea194581cbd2531e4b23759d225f6806923f63222');"));
  auto listed = s.ListKeyframes(1, false);
  ASSERT_OK(listed.status());
  std::vector<KeyframeRecord> keyframes = *listed;
  ASSERT_EQ(keyframes.size(), 2u);
  EXPECT_FALSE(keyframes[0].culled);
  EXPECT_FALSE(keyframes[1].culled);

  WriteBatch batch;
  batch.culled_keyframes.emplace_back(1, 8);
  ASSERT_OK(s.Write(batch).status());
  listed = s.ListKeyframes(1, /*with_images=*/true);
  ASSERT_OK(listed.status());
  keyframes = *listed;
  ASSERT_EQ(keyframes.size(), 2u);
  EXPECT_FALSE(keyframes[0].culled);
  EXPECT_TRUE(keyframes[1].culled);
  EXPECT_EQ(keyframes[1].colour.bytes, std::string("\x01"));  // images and pose stay
  EXPECT_EQ(keyframes[1].T_world_camera.translation(), Eigen::Vector3d(1, 2, 3));
  EXPECT_EQ(*s.connection().QueryInt64("SELECT COUNT(*) FROM keyframe_features"), 1);
  EXPECT_EQ(*s.connection().QueryInt64("SELECT keyframe_id FROM keyframe_features"), 1);
  // An unknown keyframe: NOT_FOUND, and the batch leaves nothing behind.
  WriteBatch unknown;
  unknown.culled_keyframes.emplace_back(1, 4);
  unknown.culled_keyframes.emplace_back(1, 5);
  EXPECT_EQ(s.Write(unknown).status().code(), StatusCode::kNotFound);
  EXPECT_FALSE((*s.ListKeyframes(1, false))[0].culled);
  EXPECT_FALSE(s.connection().Exec("UPDATE keyframes SET culled = 2").ok());  // CHECK
  EXPECT_OK(s.IntegrityCheck());
}

}  // namespace
}  // namespace semmap::sqlite
