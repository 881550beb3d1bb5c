// SqliteMapStore objects: types with views, observations, per-map instance replacement, the
// instance queries (R*Tree radius search against brute force) and cascades.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>

#include "storage/sqlite/sqlite_map_store.h"
#include "tests/unit/storage/storage_test_util.h"

namespace semmap {
namespace {

using storage_test::Keyframe;
using storage_test::NewSession;
using storage_test::TempDir;

ObjectView View(const std::string& tag) {
  ObjectView view;
  view.image = {"jpeg", "photo-" + tag};
  view.width = 640;
  view.height = 480;
  view.features_format = "semmap-features-v1";
  view.features = std::string("\0\1features-", 11) + tag + std::string(40, 'f');
  return view;
}

ObjectType Type(const std::string& label, std::optional<int64_t> map_id = std::nullopt,
                int views = 1) {
  ObjectType type;
  type.label = label;
  type.map_id = map_id;
  type.rgb = {10, 20, 30};
  for (int i = 0; i < views; ++i) type.views.push_back(View(label + std::to_string(i)));
  return type;
}

ObjectInstance Instance(int64_t type_id, const Eigen::Vector3d& position, double confidence = 0.5,
                        std::vector<int64_t> session_ids = {}) {
  ObjectInstance instance;
  instance.type_id = type_id;
  instance.position = position;
  instance.extent = Eigen::Vector3d(0.3, 0.2, 0.1);
  instance.confidence = confidence;
  instance.observations = 4;
  instance.session_ids = std::move(session_ids);
  instance.first_seen_ns = 100;
  instance.last_seen_ns = 200;
  return instance;
}

ObjectObservation Observation(int64_t map_id, int64_t type_id, int64_t session_id, int64_t seq) {
  ObjectObservation o;
  o.map_id = map_id;
  o.type_id = type_id;
  o.session_id = session_id;
  o.seq = seq;
  o.p_keyframe = Eigen::Vector3d(0.1, -0.2, 1.5 + static_cast<double>(seq));
  o.extent = Eigen::Vector3d(0.4, 0.3, 0.2);
  o.matches = 50;
  o.inliers = 30;
  o.xi = 2.5;
  o.stamp_ns = 1'000 + seq;
  return o;
}

class ObjectStoreTest : public ::testing::Test {
 protected:
  void SetUp() override { Reopen(); }
  void Reopen() {
    store_.reset();
    auto store = SqliteMapStore::Open(dir_.File("semmap.db"), SqliteOptions{});
    ASSERT_TRUE(store.ok()) << store.status().ToString();
    store_ = std::move(store).value();
  }

  int64_t Map(const std::string& name) {
    auto map = store_->GetOrCreateMap(name);
    EXPECT_TRUE(map.ok()) << map.status().ToString();
    return map.ok() ? map->id : 0;
  }
  SessionInfo Session(int64_t map_id, const std::string& name) {
    auto session = store_->CreateSession(NewSession(map_id, name));
    EXPECT_TRUE(session.ok()) << session.status().ToString();
    return session.ok() ? *session : SessionInfo{};
  }
  ObjectType Create(const ObjectType& type) {
    auto created = store_->CreateObjectType(type);
    EXPECT_TRUE(created.ok()) << created.status().ToString();
    return created.ok() ? *created : ObjectType{};
  }
  WriteResult Write(const WriteBatch& batch) {
    auto result = store_->Write(batch);
    EXPECT_TRUE(result.ok()) << result.status().ToString();
    return result.ok() ? *result : WriteResult{};
  }
  void WriteInstances(int64_t map_id, std::vector<ObjectInstance> instances) {
    WriteBatch batch;
    batch.instances.emplace_back(map_id, std::move(instances));
    Write(batch);
  }
  std::vector<ObjectInstance> Find(std::optional<int64_t> map_id, const std::string& label = "") {
    auto found = store_->FindObjectInstances(map_id, label);
    EXPECT_TRUE(found.ok()) << found.status().ToString();
    return found.ok() ? *found : std::vector<ObjectInstance>{};
  }
  std::vector<std::string> Labels(std::optional<int64_t> map_id) {
    auto types = store_->ListObjectTypes(map_id, false);
    EXPECT_TRUE(types.ok()) << types.status().ToString();
    std::vector<std::string> labels;
    if (!types.ok()) return labels;
    for (const ObjectType& t : *types) labels.push_back(t.label + "@" + t.map_name);
    return labels;
  }
  int64_t Count(const std::string& table) {
    return *store_->connection().QueryInt64("SELECT COUNT(*) FROM " + table);
  }

  TempDir dir_;
  std::unique_ptr<SqliteMapStore> store_;
};

// --- types ---

TEST_F(ObjectStoreTest, CreateListAndRemoveGlobalAndMapTypes) {
  const int64_t lab = Map("lab");
  const int64_t home = Map("home");
  const ObjectType global = Create(Type("laptop", std::nullopt, 2));
  EXPECT_GT(global.id, 0);
  EXPECT_FALSE(global.map_id.has_value());
  EXPECT_TRUE(global.map_name.empty());
  EXPECT_GT(global.created_unix_ns, 0);  // 0 means now
  ASSERT_EQ(global.views.size(), 2u);
  EXPECT_GT(global.views[0].id, 0);
  EXPECT_GT(global.views[1].id, global.views[0].id);

  ObjectType own = Type("laptop", lab);
  own.created_unix_ns = 42;
  const ObjectType lab_laptop = Create(own);  // the same label in another scope
  EXPECT_EQ(lab_laptop.map_name, "lab");
  EXPECT_EQ(lab_laptop.created_unix_ns, 42);
  Create(Type("mug", home));
  Create(Type("chair"));

  EXPECT_EQ(Labels(lab), (std::vector<std::string>{"chair@", "laptop@", "laptop@lab"}));
  EXPECT_EQ(Labels(home), (std::vector<std::string>{"chair@", "laptop@", "mug@home"}));
  EXPECT_EQ(Labels(std::nullopt),
            (std::vector<std::string>{"chair@", "laptop@", "laptop@lab", "mug@home"}));

  auto bare = store_->ListObjectTypes(lab, /*with_views=*/false);
  ASSERT_OK(bare.status());
  for (const ObjectType& t : *bare) EXPECT_TRUE(t.views.empty());
  auto full = store_->ListObjectTypes(lab, /*with_views=*/true);
  ASSERT_OK(full.status());
  const ObjectType& read = (*full)[1];
  EXPECT_EQ(read.id, global.id);
  EXPECT_EQ(read.rgb, (std::array<uint8_t, 3>{10, 20, 30}));
  EXPECT_EQ(read.created_unix_ns, global.created_unix_ns);
  ASSERT_EQ(read.views.size(), 2u);
  for (size_t i = 0; i < 2; ++i) {
    EXPECT_EQ(read.views[i].id, global.views[i].id);
    EXPECT_EQ(read.views[i].image.format, "jpeg");
    EXPECT_EQ(read.views[i].image.bytes, global.views[i].image.bytes);
    EXPECT_EQ(read.views[i].width, 640);
    EXPECT_EQ(read.views[i].height, 480);
    EXPECT_EQ(read.views[i].features_format, "semmap-features-v1");
    EXPECT_EQ(read.views[i].features, global.views[i].features);
  }
  EXPECT_EQ((*full)[2].map_id, lab);
  EXPECT_EQ((*full)[2].views.size(), 1u);

  ASSERT_OK(store_->RemoveObjectType("laptop", lab));
  EXPECT_EQ(Labels(lab), (std::vector<std::string>{"chair@", "laptop@"}));
  EXPECT_EQ(store_->RemoveObjectType("laptop", lab).code(), StatusCode::kNotFound);
  EXPECT_EQ(store_->RemoveObjectType("mug", std::nullopt).code(), StatusCode::kNotFound);
  ASSERT_OK(store_->RemoveObjectType("laptop", std::nullopt));
  EXPECT_EQ(Labels(std::nullopt), (std::vector<std::string>{"chair@", "mug@home"}));
  EXPECT_EQ(Count("object_views"), 2);  // chair's and mug's
}

TEST_F(ObjectStoreTest, TakenLabelInTheScopeIsAlreadyExists) {
  const int64_t lab = Map("lab");
  Create(Type("laptop"));
  Create(Type("laptop", lab));
  const int64_t views = Count("object_views");
  auto global = store_->CreateObjectType(Type("laptop"));
  EXPECT_EQ(global.status().code(), StatusCode::kAlreadyExists) << global.status().ToString();
  EXPECT_NE(global.status().message().find("global object type 'laptop'"), std::string::npos);
  auto own = store_->CreateObjectType(Type("laptop", lab));
  EXPECT_EQ(own.status().code(), StatusCode::kAlreadyExists);
  EXPECT_NE(own.status().message().find("of map 'lab'"), std::string::npos);
  EXPECT_EQ(Count("object_types"), 2);
  EXPECT_EQ(Count("object_views"), views);
}

TEST_F(ObjectStoreTest, UnknownMapIsNotFound) {
  EXPECT_EQ(store_->CreateObjectType(Type("laptop", 999)).status().code(), StatusCode::kNotFound);
  EXPECT_EQ(store_->ListObjectTypes(999, false).status().code(), StatusCode::kNotFound);
  EXPECT_EQ(store_->RemoveObjectType("laptop", 999).code(), StatusCode::kNotFound);
  EXPECT_EQ(store_->ListObjectObservations(999).status().code(), StatusCode::kNotFound);
  EXPECT_EQ(store_->FindObjectInstances(999, "").status().code(), StatusCode::kNotFound);
  EXPECT_EQ(store_->ObjectInstancesNear(999, Eigen::Vector3d::Zero(), 1, "").status().code(),
            StatusCode::kNotFound);
  EXPECT_EQ(Count("object_types"), 0);
}

TEST_F(ObjectStoreTest, InvalidTypesAreRejected) {
  for (const std::string& label :
       {std::string(), std::string("a/b"), std::string(" lead"), std::string("trail "),
        std::string("tab\there"), std::string(129, 'x')}) {
    EXPECT_EQ(store_->CreateObjectType(Type(label)).status().code(), StatusCode::kInvalidArgument)
        << "'" << label << "'";
  }
  Create(Type("teddy bear"));  // spaces inside are fine, as in map names
  Create(Type(std::string(128, 'x')));
  EXPECT_EQ(store_->CreateObjectType(Type("no views", std::nullopt, 0)).status().code(),
            StatusCode::kInvalidArgument);
  ObjectType no_image = Type("a");
  no_image.views[0].image.bytes.clear();
  ObjectType no_features = Type("b");
  no_features.views[0].features.clear();
  ObjectType no_format = Type("c");
  no_format.views[0].features_format.clear();
  for (const ObjectType& bad : {no_image, no_features, no_format}) {
    auto status = store_->CreateObjectType(bad).status();
    EXPECT_EQ(status.code(), StatusCode::kInvalidArgument) << status.ToString();
    EXPECT_NE(status.message().find("view 0"), std::string::npos) << status.ToString();
  }
  EXPECT_EQ(Count("object_types"), 2);
}

TEST_F(ObjectStoreTest, CorruptedViewFeaturesAreDataLoss) {
  const ObjectType type = Create(Type("laptop"));
  const size_t size = type.views[0].features.size();
  ASSERT_OK(store_->connection().Exec("UPDATE object_views SET features = zeroblob(" +
                                      std::to_string(size) + ")"));
  auto read = store_->ListObjectTypes(std::nullopt, /*with_views=*/true);
  EXPECT_EQ(read.status().code(), StatusCode::kDataLoss) << read.status().ToString();
  EXPECT_NE(read.status().message().find("object type 'laptop'"), std::string::npos);
  EXPECT_OK(store_->ListObjectTypes(std::nullopt, /*with_views=*/false).status());
  // A truncated value fails its stored length.
  ASSERT_OK(store_->connection().Exec("UPDATE object_views SET features = x'00'"));
  EXPECT_EQ(store_->ListObjectTypes(std::nullopt, true).status().code(), StatusCode::kDataLoss);
}

// --- observations ---

TEST_F(ObjectStoreTest, ObservationsNameKeyframesBySeqInTheSameBatch) {
  const int64_t lab = Map("lab");
  const SessionInfo s = Session(lab, "s1");
  const ObjectType laptop = Create(Type("laptop"));
  const ObjectType mug = Create(Type("mug", lab));
  WriteBatch first;
  first.keyframes = {Keyframe(s.id, 0)};
  const int64_t kf0 = Write(first).keyframe_ids.at(0);

  WriteBatch batch;
  batch.keyframes = {Keyframe(s.id, 5), Keyframe(s.id, 9)};
  batch.observations = {Observation(lab, mug.id, s.id, 9), Observation(lab, laptop.id, s.id, 5)};
  ObjectObservation by_id = Observation(lab, laptop.id, 0, -1);
  by_id.keyframe_id = kf0;
  batch.observations.push_back(by_id);
  const WriteResult written = Write(batch);
  ASSERT_EQ(written.keyframe_ids.size(), 2u);

  auto listed = store_->ListObjectObservations(lab);
  ASSERT_OK(listed.status());
  ASSERT_EQ(listed->size(), 3u);
  // Keyframe order, not batch order.
  EXPECT_EQ((*listed)[0].keyframe_id, kf0);
  EXPECT_EQ((*listed)[0].seq, 0);
  EXPECT_EQ((*listed)[1].keyframe_id, written.keyframe_ids[0]);
  EXPECT_EQ((*listed)[1].label, "laptop");
  EXPECT_EQ((*listed)[2].keyframe_id, written.keyframe_ids[1]);
  const ObjectObservation& o = (*listed)[2];
  const ObjectObservation& sent = batch.observations[0];
  EXPECT_GT(o.id, 0);
  EXPECT_EQ(o.map_id, lab);
  EXPECT_EQ(o.type_id, mug.id);
  EXPECT_EQ(o.label, "mug");
  EXPECT_EQ(o.session_id, s.id);
  EXPECT_EQ(o.seq, 9);
  EXPECT_EQ(o.p_keyframe, sent.p_keyframe);
  EXPECT_EQ(o.extent, sent.extent);
  EXPECT_EQ(o.matches, 50);
  EXPECT_EQ(o.inliers, 30);
  EXPECT_EQ(o.xi, 2.5);
  EXPECT_EQ(o.stamp_ns, sent.stamp_ns);
  EXPECT_TRUE(store_->ListObjectObservations(Map("other"))->empty());
}

TEST_F(ObjectStoreTest, BadObservationFailsTheWholeBatch) {
  const int64_t lab = Map("lab");
  const int64_t home = Map("home");
  const SessionInfo s = Session(lab, "s1");
  const SessionInfo elsewhere = Session(home, "s2");
  const ObjectType laptop = Create(Type("laptop"));
  const ObjectType homes = Create(Type("sofa", home));
  WriteBatch other;
  other.keyframes = {Keyframe(elsewhere.id, 0)};
  const int64_t home_kf = Write(other).keyframe_ids.at(0);

  auto attempt = [&](const ObjectObservation& o) {
    WriteBatch batch;
    batch.frames = {{s.id, storage_test::FramePose(3, true)}};
    batch.keyframes = {Keyframe(s.id, 3)};
    batch.observations = {Observation(lab, laptop.id, s.id, 3), o};
    return store_->Write(batch).status();
  };
  Status missing_seq = attempt(Observation(lab, laptop.id, s.id, 99));
  EXPECT_EQ(missing_seq.code(), StatusCode::kNotFound) << missing_seq.ToString();
  EXPECT_NE(missing_seq.message().find("object observation 1"), std::string::npos);
  ObjectObservation missing_id = Observation(lab, laptop.id, 0, -1);
  missing_id.keyframe_id = 12345;
  EXPECT_EQ(attempt(missing_id).code(), StatusCode::kNotFound);
  EXPECT_EQ(attempt(Observation(lab, laptop.id, 0, -1)).code(), StatusCode::kInvalidArgument);
  ObjectObservation other_map_kf = Observation(lab, laptop.id, 0, -1);
  other_map_kf.keyframe_id = home_kf;
  EXPECT_EQ(attempt(other_map_kf).code(), StatusCode::kInvalidArgument);
  EXPECT_EQ(attempt(Observation(lab, 777, s.id, 3)).code(), StatusCode::kNotFound);
  EXPECT_EQ(attempt(Observation(lab, homes.id, s.id, 3)).code(), StatusCode::kInvalidArgument);
  EXPECT_EQ(attempt(Observation(999, laptop.id, s.id, 3)).code(), StatusCode::kNotFound);
  ObjectObservation nan = Observation(lab, laptop.id, s.id, 3);
  nan.p_keyframe.x() = std::numeric_limits<double>::quiet_NaN();
  EXPECT_EQ(attempt(nan).code(), StatusCode::kInvalidArgument);
  // Rolled back with everything else of its batch.
  EXPECT_EQ(Count("object_observations"), 0);
  EXPECT_EQ(Count("frames"), 0);
  EXPECT_EQ(Count("keyframes"), 1);  // home's, from its own batch
}

// --- instances ---

TEST_F(ObjectStoreTest, InstancesAreReplacedPerMap) {
  const int64_t lab = Map("lab");
  const int64_t home = Map("home");
  const ObjectType laptop = Create(Type("laptop"));
  WriteBatch first;
  first.instances.emplace_back(lab, std::vector<ObjectInstance>{Instance(laptop.id, {1, 0, 0}),
                                                                Instance(laptop.id, {2, 0, 0}),
                                                                Instance(laptop.id, {3, 0, 0})});
  first.instances.emplace_back(home, std::vector<ObjectInstance>{Instance(laptop.id, {0, 1, 0}),
                                                                 Instance(laptop.id, {0, 2, 0})});
  Write(first);
  EXPECT_EQ(Find(lab).size(), 3u);
  EXPECT_EQ(Count("object_instances_rtree"), 5);

  const std::vector<ObjectInstance> before = Find(std::nullopt);
  const int64_t highest = std::max_element(before.begin(), before.end(), [](auto& a, auto& b) {
                            return a.id < b.id;
                          })->id;
  WriteInstances(home, Find(home));  // the newest ids are replaced: they are not reused
  ASSERT_EQ(Find(home).size(), 2u);
  EXPECT_GT(Find(home)[0].id, highest);
  WriteInstances(lab, {Instance(laptop.id, {9, 9, 9})});
  const std::vector<ObjectInstance> now = Find(lab);
  ASSERT_EQ(now.size(), 1u);
  EXPECT_EQ(now[0].position, Eigen::Vector3d(9, 9, 9));
  EXPECT_EQ(Find(home).size(), 2u);  // untouched
  EXPECT_EQ(Count("object_instances_rtree"), 3);
  auto near_old = store_->ObjectInstancesNear(lab, {2, 0, 0}, 1.5, "");
  ASSERT_OK(near_old.status());
  EXPECT_TRUE(near_old->empty());  // the replaced ones left the R*Tree too

  WriteInstances(lab, {});  // the fusion found nothing any more
  EXPECT_TRUE(Find(lab).empty());
  EXPECT_EQ(Count("object_instances_rtree"), 2);
  EXPECT_OK(store_->IntegrityCheck());
}

TEST_F(ObjectStoreTest, InvalidInstancesFailTheBatchAndKeepTheOldOnes) {
  const int64_t lab = Map("lab");
  const int64_t home = Map("home");
  const SessionInfo home_session = Session(home, "h");
  const ObjectType laptop = Create(Type("laptop"));
  const ObjectType sofa = Create(Type("sofa", home));
  WriteInstances(lab, {Instance(laptop.id, {1, 2, 3})});

  std::vector<ObjectInstance> bad;
  bad.push_back(Instance(laptop.id, {1, 1, 1}, 1.5));
  bad.push_back(Instance(laptop.id, {std::nan(""), 1, 1}));
  bad.push_back(Instance(laptop.id, {1, 1, 1}, std::nan("")));
  bad.push_back(Instance(laptop.id, {1, 1, 1}));
  bad.back().extent.y() = -1;
  bad.push_back(Instance(laptop.id, {1, 1, 1}));
  bad.back().label = "mug";
  bad.push_back(Instance(laptop.id, {1, 1, 1}));
  bad.back().map_id = home;
  bad.push_back(Instance(sofa.id, {1, 1, 1}));                            // home's type
  bad.push_back(Instance(laptop.id, {1, 1, 1}, 0.5, {home_session.id}));  // home's session
  for (const ObjectInstance& instance : bad) {
    WriteBatch batch;
    batch.instances.emplace_back(
        lab, std::vector<ObjectInstance>{Instance(laptop.id, {0, 0, 0}), instance});
    auto status = store_->Write(batch).status();
    EXPECT_EQ(status.code(), StatusCode::kInvalidArgument) << status.ToString();
    EXPECT_NE(status.message().find("instance 1"), std::string::npos) << status.ToString();
  }
  WriteBatch missing;
  missing.instances.emplace_back(lab, std::vector<ObjectInstance>{Instance(777, {0, 0, 0})});
  EXPECT_EQ(store_->Write(missing).status().code(), StatusCode::kNotFound);
  missing.instances[0].second = {Instance(laptop.id, {0, 0, 0}, 0.5, {4242})};
  EXPECT_EQ(store_->Write(missing).status().code(), StatusCode::kNotFound);
  missing.instances[0] = {999, {Instance(laptop.id, {0, 0, 0})}};
  EXPECT_EQ(store_->Write(missing).status().code(), StatusCode::kNotFound);

  const std::vector<ObjectInstance> kept = Find(lab);
  ASSERT_EQ(kept.size(), 1u);
  EXPECT_EQ(kept[0].position, Eigen::Vector3d(1, 2, 3));
  EXPECT_EQ(Count("object_instances_rtree"), 1);
}

TEST_F(ObjectStoreTest, FindFiltersOrdersAndNamesSessions) {
  // Created in this order so ids and names disagree: ordering is by map name.
  const int64_t beta = Map("beta");
  const int64_t alpha = Map("alpha");
  const SessionInfo a1 = Session(alpha, "morning");
  const SessionInfo a2 = Session(alpha, "evening");
  const SessionInfo b1 = Session(beta, "only");
  const ObjectType mug = Create(Type("mug"));
  const ObjectType laptop = Create(Type("laptop"));
  const ObjectType chair = Create(Type("chair", beta));
  WriteBatch batch;
  batch.instances.emplace_back(
      beta, std::vector<ObjectInstance>{Instance(mug.id, {0, 0, 0}, 0.2, {b1.id}),
                                        Instance(chair.id, {1, 0, 0}, 0.9, {b1.id})});
  batch.instances.emplace_back(
      alpha, std::vector<ObjectInstance>{Instance(mug.id, {0, 0, 1}, 0.3, {a2.id, a1.id, a2.id}),
                                         Instance(laptop.id, {0, 0, 2}, 0.1),
                                         Instance(mug.id, {0, 0, 3}, 0.8, {a1.id}),
                                         Instance(laptop.id, {0, 0, 4}, 0.7)});
  Write(batch);

  auto key = [](const std::vector<ObjectInstance>& found) {
    std::vector<std::string> keys;
    keys.reserve(found.size());
    for (const ObjectInstance& o : found) {
      keys.push_back(o.map_name + "/" + o.label + "/" + std::to_string(o.confidence).substr(0, 3));
    }
    return keys;
  };
  EXPECT_EQ(key(Find(std::nullopt)),
            (std::vector<std::string>{"alpha/laptop/0.7", "alpha/laptop/0.1", "alpha/mug/0.8",
                                      "alpha/mug/0.3", "beta/chair/0.9", "beta/mug/0.2"}));
  EXPECT_EQ(key(Find(std::nullopt, "mug")),
            (std::vector<std::string>{"alpha/mug/0.8", "alpha/mug/0.3", "beta/mug/0.2"}));
  EXPECT_EQ(key(Find(beta)), (std::vector<std::string>{"beta/chair/0.9", "beta/mug/0.2"}));
  EXPECT_EQ(key(Find(alpha, "laptop")),
            (std::vector<std::string>{"alpha/laptop/0.7", "alpha/laptop/0.1"}));
  EXPECT_TRUE(Find(alpha, "chair").empty());
  EXPECT_TRUE(Find(std::nullopt, "sofa").empty());

  const std::vector<ObjectInstance> mugs = Find(alpha, "mug");
  ASSERT_EQ(mugs.size(), 2u);
  const ObjectInstance& seen_twice = mugs[1];
  EXPECT_GT(seen_twice.id, 0);
  EXPECT_EQ(seen_twice.map_id, alpha);
  EXPECT_EQ(seen_twice.type_id, mug.id);
  EXPECT_EQ(seen_twice.position, Eigen::Vector3d(0, 0, 1));
  EXPECT_EQ(seen_twice.extent, Eigen::Vector3d(0.3, 0.2, 0.1));
  EXPECT_EQ(seen_twice.observations, 4);
  EXPECT_EQ(seen_twice.first_seen_ns, 100);
  EXPECT_EQ(seen_twice.last_seen_ns, 200);
  // Stored once each, ascending; names in the same order.
  EXPECT_EQ(seen_twice.session_ids, (std::vector<int64_t>{a1.id, a2.id}));
  EXPECT_EQ(seen_twice.sessions, (std::vector<std::string>{"morning", "evening"}));
  EXPECT_EQ(mugs[0].sessions, (std::vector<std::string>{"morning"}));
  EXPECT_TRUE(Find(alpha, "laptop")[0].sessions.empty());
  // The label comes from the type when the instance leaves it empty.
  EXPECT_EQ(Find(beta, "chair")[0].label, "chair");
}

TEST_F(ObjectStoreTest, NearMatchesBruteForce) {
  const int64_t lab = Map("lab");
  const int64_t other = Map("other");
  const std::vector<ObjectType> types = {Create(Type("mug")), Create(Type("laptop")),
                                         Create(Type("chair", lab))};
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> coord(-10, 10);
  std::vector<ObjectInstance> instances;
  for (int i = 0; i < 500; ++i) {
    // Some clustered duplicates so ties and dense regions occur.
    const Eigen::Vector3d p = i % 50 == 49 ? instances[i - 1].position
                                           : Eigen::Vector3d(coord(rng), coord(rng), coord(rng));
    instances.push_back(Instance(types[i % 3].id, p, 0.5));
  }
  WriteInstances(lab, instances);
  // The same places in another map must not leak into lab's answers.
  std::vector<ObjectInstance> decoys(instances.begin(), instances.begin() + 100);
  for (ObjectInstance& d : decoys) d.type_id = types[0].id;
  WriteInstances(other, decoys);
  const std::vector<ObjectInstance> stored = Find(lab);
  ASSERT_EQ(stored.size(), 500u);

  int checked = 0;
  for (int q = 0; q < 12; ++q) {
    const Eigen::Vector3d centre = q == 0 ? stored[3].position  // exactly on an instance
                                          : Eigen::Vector3d(coord(rng), coord(rng), coord(rng));
    for (double radius : {0.0, 0.7, 2.5, 6.0, 40.0}) {
      for (const std::string& label : {std::string(), std::string("laptop")}) {
        std::vector<std::pair<double, int64_t>> expected;
        for (const ObjectInstance& o : stored) {
          const double d = (o.position - centre).norm();
          if (d <= radius && (label.empty() || o.label == label)) expected.emplace_back(d, o.id);
        }
        std::sort(expected.begin(), expected.end());
        auto near = store_->ObjectInstancesNear(lab, centre, radius, label);
        ASSERT_OK(near.status());
        ASSERT_EQ(near->size(), expected.size()) << "radius " << radius << " label " << label;
        for (size_t i = 0; i < expected.size(); ++i) {
          EXPECT_EQ((*near)[i].id, expected[i].second);
          EXPECT_EQ((*near)[i].distance_m, expected[i].first);
          EXPECT_EQ((*near)[i].map_id, lab);
          EXPECT_EQ((*near)[i].map_name, "lab");
        }
        checked += static_cast<int>(expected.size());
      }
    }
  }
  EXPECT_GT(checked, 1000);  // the queries were not all empty
  auto whole = store_->ObjectInstancesNear(lab, Eigen::Vector3d::Zero(), 100, "");
  ASSERT_OK(whole.status());
  EXPECT_EQ(whole->size(), 500u);
  auto on_point = store_->ObjectInstancesNear(lab, stored[3].position, 0, "");
  ASSERT_OK(on_point.status());
  ASSERT_GE(on_point->size(), 1u);
  EXPECT_EQ((*on_point)[0].distance_m, 0);
}

TEST_F(ObjectStoreTest, NearIncludesTheBoundaryDespiteFloatBoxes) {
  // The R*Tree keeps 32-bit floats; 0.1 is not one, and the instance sits exactly on the sphere.
  const int64_t lab = Map("lab");
  const ObjectType mug = Create(Type("mug"));
  WriteInstances(lab, {Instance(mug.id, {0.1, 0, 0}), Instance(mug.id, {0, -0.3, 0}),
                       Instance(mug.id, {0, 0, 0.1000001})});
  auto near = store_->ObjectInstancesNear(lab, Eigen::Vector3d::Zero(), 0.1, "");
  ASSERT_OK(near.status());
  ASSERT_EQ(near->size(), 1u);
  EXPECT_EQ((*near)[0].position.x(), 0.1);
  EXPECT_EQ((*near)[0].distance_m, 0.1);
  near = store_->ObjectInstancesNear(lab, Eigen::Vector3d::Zero(), 0.3, "");
  ASSERT_OK(near.status());
  ASSERT_EQ(near->size(), 3u);
  EXPECT_EQ((*near)[2].position.y(), -0.3);
}

TEST_F(ObjectStoreTest, NearValidatesItsArguments) {
  const int64_t lab = Map("lab");
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const double inf = std::numeric_limits<double>::infinity();
  for (double radius : {-0.1, nan, inf}) {
    EXPECT_EQ(store_->ObjectInstancesNear(lab, Eigen::Vector3d::Zero(), radius, "").status().code(),
              StatusCode::kInvalidArgument)
        << radius;
  }
  EXPECT_EQ(store_->ObjectInstancesNear(lab, {0, nan, 0}, 1, "").status().code(),
            StatusCode::kInvalidArgument);
  EXPECT_EQ(store_->ObjectInstancesNear(lab, {inf, 0, 0}, 1, "").status().code(),
            StatusCode::kInvalidArgument);
  EXPECT_OK(store_->ObjectInstancesNear(lab, Eigen::Vector3d::Zero(), 0, "").status());
}

TEST_F(ObjectStoreTest, NearSearchesThroughTheRtree) {
  const int64_t lab = Map("lab");
  const ObjectType mug = Create(Type("mug"));
  WriteInstances(lab, {Instance(mug.id, {1, 1, 1})});
  EXPECT_EQ(store_->ObjectInstancesNear(lab, {1, 1, 1}, 0.5, "")->size(), 1u);
  // Without its index rows an instance is invisible to radius queries, found by the others.
  ASSERT_OK(store_->connection().Exec("DELETE FROM object_instances_rtree"));
  EXPECT_TRUE(store_->ObjectInstancesNear(lab, {1, 1, 1}, 0.5, "")->empty());
  EXPECT_EQ(Find(lab).size(), 1u);
}

// --- cascades ---

TEST_F(ObjectStoreTest, RemovingATypeCascadesToEverythingOfIt) {
  const int64_t lab = Map("lab");
  const int64_t home = Map("home");
  const SessionInfo s = Session(lab, "s");
  const ObjectType mug = Create(Type("mug", std::nullopt, 3));
  const ObjectType laptop = Create(Type("laptop"));
  WriteBatch batch;
  batch.keyframes = {Keyframe(s.id, 0), Keyframe(s.id, 1)};
  batch.observations = {Observation(lab, mug.id, s.id, 0), Observation(lab, laptop.id, s.id, 0),
                        Observation(lab, mug.id, s.id, 1)};
  batch.instances.emplace_back(lab, std::vector<ObjectInstance>{Instance(mug.id, {0, 0, 0}),
                                                                Instance(laptop.id, {1, 0, 0})});
  batch.instances.emplace_back(home, std::vector<ObjectInstance>{Instance(mug.id, {0, 0, 0})});
  Write(batch);
  EXPECT_EQ(Count("object_instances_rtree"), 3);

  ASSERT_OK(store_->RemoveObjectType("mug", std::nullopt));
  EXPECT_EQ(Count("object_views"), 1);
  const auto observations = store_->ListObjectObservations(lab);
  ASSERT_EQ(observations->size(), 1u);
  EXPECT_EQ((*observations)[0].label, "laptop");
  EXPECT_EQ(Find(std::nullopt).size(), 1u);
  EXPECT_TRUE(Find(home).empty());
  EXPECT_EQ(Count("object_instances_rtree"), 1);
  EXPECT_EQ(*store_->connection().QueryInt64("SELECT COUNT(*) FROM object_instances_rtree r"
                                             " JOIN object_instances i ON i.id = r.id"),
            1);
  EXPECT_TRUE(store_->ObjectInstancesNear(home, Eigen::Vector3d::Zero(), 1, "")->empty());
  EXPECT_OK(store_->IntegrityCheck());
}

TEST_F(ObjectStoreTest, DeletedKeyframesAndMapsTakeTheirObjectsAlong) {
  // The store has no delete API yet; the schema's cascades are what a future one relies on.
  const int64_t lab = Map("lab");
  const int64_t home = Map("home");
  const SessionInfo s = Session(lab, "s");
  const ObjectType mug = Create(Type("mug"));
  Create(Type("lamp", lab));
  WriteBatch batch;
  batch.keyframes = {Keyframe(s.id, 0), Keyframe(s.id, 1)};
  batch.observations = {Observation(lab, mug.id, s.id, 0), Observation(lab, mug.id, s.id, 1)};
  batch.instances.emplace_back(lab, std::vector<ObjectInstance>{Instance(mug.id, {0, 0, 0})});
  batch.instances.emplace_back(home, std::vector<ObjectInstance>{Instance(mug.id, {0, 0, 0})});
  const WriteResult written = Write(batch);
  ASSERT_OK(store_->connection().Exec("DELETE FROM keyframes WHERE id = " +
                                      std::to_string(written.keyframe_ids.at(0))));
  ASSERT_EQ(store_->ListObjectObservations(lab)->size(), 1u);
  ASSERT_OK(store_->connection().Exec("DELETE FROM maps WHERE name = 'lab'"));
  EXPECT_EQ(Count("object_observations"), 0);
  EXPECT_EQ(Labels(std::nullopt), (std::vector<std::string>{"mug@"}));
  EXPECT_EQ(Find(std::nullopt).size(), 1u);
  EXPECT_EQ(Count("object_instances_rtree"), 1);  // lab's box went with its instance
  EXPECT_OK(store_->IntegrityCheck());
}

TEST_F(ObjectStoreTest, ObjectsPersistAcrossReopen) {
  const int64_t lab = Map("lab");
  const ObjectType mug = Create(Type("mug"));
  WriteInstances(lab, {Instance(mug.id, {1, 2, 3}, 0.6)});
  Reopen();
  ASSERT_EQ(store_->ListObjectTypes(lab, true)->size(), 1u);
  EXPECT_EQ((*store_->ListObjectTypes(lab, true))[0].views[0].features, mug.views[0].features);
  auto near = store_->ObjectInstancesNear(lab, {1, 2, 3.5}, 1, "mug");
  ASSERT_OK(near.status());
  ASSERT_EQ(near->size(), 1u);
  EXPECT_EQ((*near)[0].distance_m, 0.5);
  EXPECT_EQ((*near)[0].confidence, 0.6);
}

// --- WriteBatch::Append ---

TEST(WriteBatchAppendTest, ObservationsConcatenateAndLaterInstancesWin) {
  WriteBatch merged;
  WriteBatch a;
  a.observations.resize(2);
  a.instances.emplace_back(1, std::vector<ObjectInstance>(3));
  a.instances.emplace_back(2, std::vector<ObjectInstance>(1));
  WriteBatch b;
  b.observations.resize(1);
  b.observations[0].seq = 7;
  b.instances.emplace_back(1, std::vector<ObjectInstance>(5));
  b.instances.emplace_back(3, std::vector<ObjectInstance>{});
  merged.Append(std::move(a));
  merged.Append(std::move(b));
  // What Append leaves behind in its argument is part of its contract.
  // NOLINTBEGIN(bugprone-use-after-move)
  EXPECT_TRUE(b.observations.empty());
  EXPECT_TRUE(b.instances.empty());
  // NOLINTEND(bugprone-use-after-move)
  ASSERT_EQ(merged.observations.size(), 3u);
  EXPECT_EQ(merged.observations[2].seq, 7);
  ASSERT_EQ(merged.instances.size(), 3u);
  EXPECT_EQ(merged.instances[0].first, 1);
  EXPECT_EQ(merged.instances[0].second.size(), 5u);  // b's replacement of map 1
  EXPECT_EQ(merged.instances[1].first, 2);
  EXPECT_EQ(merged.instances[1].second.size(), 1u);
  EXPECT_EQ(merged.instances[2].first, 3);
  EXPECT_TRUE(merged.instances[2].second.empty());  // an empty list still clears its map
  EXPECT_FALSE(merged.empty());
  WriteBatch only_instances;
  only_instances.instances.emplace_back(4, std::vector<ObjectInstance>{});
  EXPECT_FALSE(only_instances.empty());
}

}  // namespace
}  // namespace semmap
