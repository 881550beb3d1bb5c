// ObjectCatalog and ObjectMapper over a real SQLite store, on the synthetic room: photos are
// registered (bad ones refused with the reason), keyframes facing the book are searched,
// the observation is stored in the keyframe's frame, the instance lands at the book's front
// face, moves with its keyframes after a pose-graph correction, survives a restart of the
// mapper, and goes away with its type.
#include "core/objects/object_mapper.h"

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <memory>
#include <opencv2/imgcodecs.hpp>
#include <string>
#include <vector>

#include "core/objects/object_catalog.h"
#include "storage/sqlite/sqlite_map_store.h"
#include "storage/storage_writer.h"
#include "tests/testing/synth/object_template.h"
#include "tests/testing/test_store.h"
#include "tests/unit/recognition/recognition_scene.h"

namespace semmap {
namespace {

using recognition_test::FacingPose;
using recognition_test::MakeKeyframe;
using recognition_test::Room;
using recognition_test::RoomCamera;
using recognition_test::RoomRenderer;

const synth::NamedObject& Book() {
  for (const synth::NamedObject& o : Room().objects) {
    if (o.label == "book") return o;
  }
  std::abort();
}

EncodedImage Photo(const synth::NamedObject& object) {
  StatusOr<cv::Mat> photo = synth::RenderObjectTemplate(RoomRenderer(), object);
  EXPECT_TRUE(photo.ok());
  std::vector<uint8_t> png;
  cv::imencode(".png", *photo, png);
  return {"png", std::string(png.begin(), png.end())};
}

class ObjectMapperTest : public ::testing::Test {
 protected:
  void SetUp() override {
    StatusOr<std::unique_ptr<testing::TestStore>> store =
        testing::MakeTestStore("room", "walk", RoomCamera(), 5000);
    ASSERT_TRUE(store.ok()) << store.status().ToString();
    store_ = std::move(store).value();
    map_ = store_->map;
    session_ = store_->session;
    read_ = store_->read.get();
    writer_ = store_->writer.get();
    StatusOr<std::unique_ptr<ObjectCatalog>> catalog = ObjectCatalog::Load(writer_, {});
    ASSERT_TRUE(catalog.ok()) << catalog.status().ToString();
    catalog_ = std::move(catalog).value();

    // Three keyframes looking at the book from 0.9 m, a little apart (the neighbour check
    // needs the object in the neighbours too), stored as an ingest session stores them.
    WriteBatch batch;
    for (int i = 0; i < 3; ++i) {
      const Eigen::Isometry3d T = FacingPose(Book(), 0.9, 0.08 * (i - 1));
      keyframes_.push_back(MakeKeyframe(T));
      TrajectoryPose pose;
      pose.seq = i;
      pose.stamp_ns = 1'000'000'000 + i;
      pose.T_world_camera = T;
      pose.is_keyframe = true;
      batch.frames.emplace_back(session_.id, pose);
      KeyframeRecord record;
      record.session_id = session_.id;
      record.seq = i;
      record.stamp_ns = pose.stamp_ns;
      record.T_world_camera = T;
      record.colour = {"png", "c"};
      batch.keyframes.push_back(record);
    }
    ASSERT_TRUE(writer_->RunSync([&](MapStore& s) { return s.Write(batch).status(); }).ok());
  }

  std::unique_ptr<ObjectMapper> StartMapper(bool restore) {
    StatusOr<std::unique_ptr<ObjectMapper>> mapper = ObjectMapper::Start(
        map_.id, {}, catalog_.get(), writer_,
        restore ? StoreRestore::ThroughReader(SqliteMapStore::Opener(store_->db_path, {}))
                : StoreRestore::None());
    EXPECT_TRUE(mapper.ok()) << mapper.status().ToString();
    return mapper.ok() ? std::move(mapper).value() : nullptr;
  }

  // The keyframes (features, then poses `offset * truth`) and the session's end.
  void Feed(ObjectMapper& mapper, const Eigen::Isometry3d& offset) {
    for (size_t i = 0; i < keyframes_.size(); ++i) {
      const int64_t seq = static_cast<int64_t>(i);
      ASSERT_TRUE(mapper
                      .AddKeyframe(session_.id, seq, 1'000'000'000 + seq,
                                   std::make_shared<const FrameFeatures>(keyframes_[i].features),
                                   RoomCamera())
                      .ok());
      ASSERT_TRUE(
          mapper
              .SetKeyframePoses({{session_.id, seq, offset * keyframes_[i].T_world_camera}}, false)
              .ok());
    }
    ASSERT_TRUE(mapper.EndSession(session_.id).ok());
  }

  std::vector<KeyframePose> Poses(const Eigen::Isometry3d& offset) const {
    std::vector<KeyframePose> out;
    for (size_t i = 0; i < keyframes_.size(); ++i) {
      out.push_back({session_.id, static_cast<int64_t>(i), offset * keyframes_[i].T_world_camera});
    }
    return out;
  }

  std::vector<ObjectInstance> Instances(const std::string& label = "") {
    StatusOr<std::vector<ObjectInstance>> found = read_->FindObjectInstances(map_.id, label);
    EXPECT_TRUE(found.ok()) << found.status().ToString();
    return found.ok() ? *found : std::vector<ObjectInstance>{};
  }

  std::unique_ptr<testing::TestStore> store_;
  SqliteMapStore* read_ = nullptr;
  StorageWriter* writer_ = nullptr;
  std::unique_ptr<ObjectCatalog> catalog_;
  MapInfo map_;
  SessionInfo session_;
  std::vector<recognition_test::Keyframe> keyframes_;
};

TEST_F(ObjectMapperTest, CatalogRegistersListsAndRemovesTypes) {
  RegisterObjectInput input{"book", "", {Photo(Book())}, std::nullopt};
  StatusOr<ObjectType> book = catalog_->Register(input);
  ASSERT_TRUE(book.ok()) << book.status().ToString();
  EXPECT_GT(book->id, 0);
  EXPECT_EQ(book->views.size(), 1u);
  EXPECT_EQ(book->rgb, LabelColour("book"));
  EXPECT_EQ(catalog_->Register(input).status().code(), StatusCode::kAlreadyExists);
  // The same label for one map is another scope; an unknown map is NOT_FOUND.
  RegisterObjectInput scoped{"book", "room", {Photo(Book())}, std::array<uint8_t, 3>{1, 2, 3}};
  StatusOr<ObjectType> room_book = catalog_->Register(scoped);
  ASSERT_TRUE(room_book.ok()) << room_book.status().ToString();
  EXPECT_EQ(room_book->rgb, (std::array<uint8_t, 3>{1, 2, 3}));
  scoped.map = "nowhere";
  EXPECT_EQ(catalog_->Register(scoped).status().code(), StatusCode::kNotFound);
  // Bad photos and labels are refused with the reason.
  const std::vector<std::pair<RegisterObjectInput, std::string>> bad = {
      {{"x", "", {{"png", "garbage"}}, std::nullopt}, "decode"},
      {{"x", "", {}, std::nullopt}, "at least one photo"},
      {{"", "", {Photo(Book())}, std::nullopt}, "label"},
  };
  for (const auto& [in, reason] : bad) {
    const Status status = catalog_->Register(in).status();
    EXPECT_EQ(status.code(), StatusCode::kInvalidArgument) << status.ToString();
    EXPECT_NE(status.message().find(reason), std::string::npos) << status.ToString();
  }
  std::vector<uint8_t> plain;
  cv::imencode(".png", cv::Mat(300, 300, CV_8UC3, cv::Scalar(60, 60, 60)), plain);
  const Status featureless =
      catalog_->Register({"plain", "", {{"png", std::string(plain.begin(), plain.end())}}, {}})
          .status();
  EXPECT_EQ(featureless.code(), StatusCode::kInvalidArgument);
  EXPECT_NE(featureless.message().find("features"), std::string::npos) << featureless.ToString();

  EXPECT_EQ(catalog_->ModelsFor(map_.id)->models.size(), 2u);      // global + the map's
  EXPECT_EQ(catalog_->ModelsFor(map_.id + 1)->models.size(), 1u);  // global only
  // A catalog loaded from the store knows the same types (a restarted server).
  StatusOr<std::unique_ptr<ObjectCatalog>> reloaded = ObjectCatalog::Load(writer_, {});
  ASSERT_TRUE(reloaded.ok());
  EXPECT_EQ((*reloaded)->ModelsFor(map_.id)->models.size(), 2u);
  EXPECT_EQ((*reloaded)->ModelsFor(map_.id)->models[0].views[0].features.size(),
            catalog_->ModelsFor(map_.id)->models[0].views[0].features.size());

  ASSERT_TRUE(catalog_->Remove("book", "").ok());
  EXPECT_EQ(catalog_->Remove("book", "").code(), StatusCode::kNotFound);
  EXPECT_FALSE(catalog_->Contains(book->id));
  EXPECT_EQ(catalog_->ModelsFor(map_.id + 1)->models.size(), 0u);
  EXPECT_EQ(catalog_->ModelsFor(map_.id)->models.size(), 1u);
}

TEST_F(ObjectMapperTest, InstanceFollowsItsKeyframesThroughACorrectionAndARestart) {
  ASSERT_TRUE(catalog_->Register({"book", "", {Photo(Book())}, std::nullopt}).ok());
  std::unique_ptr<ObjectMapper> mapper = StartMapper(/*restore=*/false);
  ASSERT_NE(mapper, nullptr);
  // Tracking drifted by 30 cm and 3 degrees before the loop closure.
  Eigen::Isometry3d drift = Eigen::Isometry3d::Identity();
  drift.translation() = Eigen::Vector3d(0.3, 0, 0);
  drift.linear() = Eigen::AngleAxisd(0.05, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  Feed(*mapper, drift);
  ASSERT_TRUE(mapper->Flush().ok());
  const Eigen::Vector3d truth = Book().front.Centre();
  std::vector<ObjectInstance> found = Instances("book");
  ASSERT_EQ(found.size(), 1u);
  EXPECT_LT((found[0].position - drift * truth).norm(), 0.05);
  EXPECT_GE(found[0].observations, 2);
  EXPECT_EQ(found[0].sessions, std::vector<std::string>{"walk"});
  const ObjectMapperStats stats = mapper->stats();
  EXPECT_EQ(stats.keyframes_searched, 3u);
  EXPECT_EQ(stats.rejected_by_xi, 0u);
  EXPECT_EQ(stats.observations, static_cast<uint64_t>(found[0].observations));

  // The back end's correction puts the keyframes (and the book) where they are.
  ASSERT_TRUE(mapper->SetKeyframePoses(Poses(Eigen::Isometry3d::Identity()), true).ok());
  ASSERT_TRUE(mapper->Flush().ok());
  found = Instances("book");
  ASSERT_EQ(found.size(), 1u);
  const double error = (found[0].position - truth).norm();
  std::printf("book after the correction: %.4f m from its front face\n", error);
  EXPECT_LT(error, 0.05);
  mapper->Stop();

  // A restarted mapper reads the observations back and follows later corrections too.
  std::unique_ptr<ObjectMapper> restarted = StartMapper(/*restore=*/true);
  ASSERT_NE(restarted, nullptr);
  ASSERT_TRUE(restarted->SetKeyframePoses(Poses(drift), true).ok());
  ASSERT_TRUE(restarted->Flush().ok());
  EXPECT_EQ(restarted->stats().restored_observations, stats.observations);
  found = Instances("book");
  ASSERT_EQ(found.size(), 1u);
  EXPECT_LT((found[0].position - drift * truth).norm(), 0.05);

  // Removing the type removes its instances, now and at the next fusion.
  ASSERT_TRUE(catalog_->Remove("book", "").ok());
  EXPECT_TRUE(Instances().empty());
  ASSERT_TRUE(restarted->SetKeyframePoses(Poses(Eigen::Isometry3d::Identity()), true).ok());
  ASSERT_TRUE(restarted->Flush().ok());
  EXPECT_TRUE(Instances().empty());
}

TEST_F(ObjectMapperTest, NothingRegisteredNothingSearched) {
  std::unique_ptr<ObjectMapper> mapper = StartMapper(/*restore=*/true);
  ASSERT_NE(mapper, nullptr);
  Feed(*mapper, Eigen::Isometry3d::Identity());
  ASSERT_TRUE(mapper->Flush().ok());
  EXPECT_EQ(mapper->stats().keyframes_searched, 0u);
  EXPECT_TRUE(Instances().empty());
  EXPECT_EQ(mapper->AddKeyframe(session_.id, 9, 0, nullptr, RoomCamera()).code(),
            StatusCode::kInvalidArgument);
  mapper->Stop();
  EXPECT_EQ(mapper->Flush().code(), StatusCode::kUnavailable);
}

}  // namespace
}  // namespace semmap
