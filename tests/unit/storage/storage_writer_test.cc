// StorageWriter: callbacks after commit, merged transactions, failure isolation, ordering,
// backpressure and shutdown.
#include "storage/storage_writer.h"

#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <future>
#include <mutex>
#include <thread>
#include <vector>

#include "storage/sqlite/sqlite_map_store.h"
#include "tests/unit/storage/storage_test_util.h"

namespace semmap {
namespace {

using storage_test::FramePose;
using storage_test::Keyframe;
using storage_test::NewSession;
using storage_test::TempDir;

// Forwards to a real store and records how many rows each Write carried.
class RecordingStore final : public MapStore {
 public:
  explicit RecordingStore(std::unique_ptr<MapStore> inner) : inner_(std::move(inner)) {}

  std::vector<size_t> write_sizes() {
    std::lock_guard lock(mutex_);
    return write_sizes_;
  }

  StatusOr<std::vector<MapInfo>> ListMaps() override { return inner_->ListMaps(); }
  StatusOr<MapInfo> GetMap(const std::string& n) override { return inner_->GetMap(n); }
  StatusOr<MapInfo> GetOrCreateMap(const std::string& n) override {
    return inner_->GetOrCreateMap(n);
  }
  StatusOr<std::vector<SessionInfo>> ListSessions(const std::string& m) override {
    return inner_->ListSessions(m);
  }
  StatusOr<SessionInfo> GetSession(const std::string& m, const std::string& s) override {
    return inner_->GetSession(m, s);
  }
  StatusOr<SessionInfo> CreateSession(const SessionInfo& s) override {
    return inner_->CreateSession(s);
  }
  Status EndSession(int64_t id, int64_t ns, SessionEndReason reason,
                    const std::string& message) override {
    return inner_->EndSession(id, ns, reason, message);
  }
  StatusOr<int64_t> MarkOpenSessionsCrashed() override { return inner_->MarkOpenSessionsCrashed(); }
  StatusOr<RemovedCounts> RemoveSession(int64_t id) override { return inner_->RemoveSession(id); }
  StatusOr<RemovedCounts> RemoveMap(int64_t id) override { return inner_->RemoveMap(id); }
  StatusOr<WriteResult> Write(const WriteBatch& batch) override {
    {
      std::lock_guard lock(mutex_);
      write_sizes_.push_back(batch.frames.size() + batch.keyframes.size() + batch.links.size() +
                             batch.blobs.size());
    }
    return inner_->Write(batch);
  }
  StatusOr<std::vector<TrajectoryPose>> GetTrajectory(int64_t id, bool kf) override {
    return inner_->GetTrajectory(id, kf);
  }
  StatusOr<KeyframeRecord> GetKeyframe(int64_t id) override { return inner_->GetKeyframe(id); }
  StatusOr<std::vector<KeyframeRecord>> ListKeyframes(int64_t id, bool images) override {
    return inner_->ListKeyframes(id, images);
  }
  StatusOr<std::vector<KeyframeRecord>> ListKeyframeFeatures(int64_t id) override {
    return inner_->ListKeyframeFeatures(id);
  }
  StatusOr<KeyframeRecord> GetKeyframeFeatures(int64_t session_id, int64_t seq) override {
    return inner_->GetKeyframeFeatures(session_id, seq);
  }
  StatusOr<std::vector<LinkRecord>> ListLinks(int64_t id) override { return inner_->ListLinks(id); }
  StatusOr<std::vector<MapPointRecord>> ListMapPoints(int64_t id) override {
    return inner_->ListMapPoints(id);
  }
  Status UpdateKeyframePoses(
      const std::vector<std::pair<int64_t, Eigen::Isometry3d>>& poses) override {
    return inner_->UpdateKeyframePoses(poses);
  }
  // The writer never calls these itself; only what a test forwards would reach them.
  StatusOr<ObjectType> CreateObjectType(const ObjectType&) override {
    return UnimplementedError("RecordingStore::CreateObjectType");
  }
  StatusOr<std::vector<ObjectType>> ListObjectTypes(std::optional<int64_t>, bool) override {
    return UnimplementedError("RecordingStore::ListObjectTypes");
  }
  Status RemoveObjectType(const std::string&, std::optional<int64_t>) override {
    return UnimplementedError("RecordingStore::RemoveObjectType");
  }
  StatusOr<std::vector<ObjectObservation>> ListObjectObservations(int64_t) override {
    return UnimplementedError("RecordingStore::ListObjectObservations");
  }
  StatusOr<std::vector<ObjectInstance>> FindObjectInstances(std::optional<int64_t>,
                                                            const std::string&) override {
    return UnimplementedError("RecordingStore::FindObjectInstances");
  }
  StatusOr<std::vector<ObjectInstance>> ObjectInstancesNear(int64_t, const Eigen::Vector3d&, double,
                                                            const std::string&) override {
    return UnimplementedError("RecordingStore::ObjectInstancesNear");
  }
  StatusOr<MapBlob> GetBlob(int64_t id, const std::string& kind) override {
    return inner_->GetBlob(id, kind);
  }
  Status Checkpoint() override {
    ++checkpoints;
    return inner_->Checkpoint();
  }

  std::atomic<int> checkpoints{0};

 private:
  std::unique_ptr<MapStore> inner_;
  std::mutex mutex_;
  std::vector<size_t> write_sizes_;
};

// Collects callback outcomes in submission order.
struct Outcomes {
  std::mutex mutex;
  std::vector<std::pair<int, Status>> calls;  // (batch tag, status)
  std::vector<std::vector<int64_t>> keyframe_ids;

  StorageWriter::Done For(int tag) {
    return [this, tag](const Status& status, const WriteResult& result) {
      std::lock_guard lock(mutex);
      calls.emplace_back(tag, status);
      keyframe_ids.push_back(result.keyframe_ids);
    };
  }
  size_t size() {
    std::lock_guard lock(mutex);
    return calls.size();
  }
  void WaitFor(size_t n) {
    while (size() < n) std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
};

class StorageWriterTest : public ::testing::Test {
 protected:
  void SetUp() override {
    auto reader = SqliteMapStore::Open(path(), {});
    ASSERT_TRUE(reader.ok()) << reader.status().ToString();
    reader_ = std::move(reader).value();
    session_ = *reader_->CreateSession(NewSession(reader_->GetOrCreateMap("m")->id, "s"));
  }
  void StartWriter(StorageWriter::Options options = {}) {
    auto store = SqliteMapStore::Open(path(), {});
    ASSERT_TRUE(store.ok()) << store.status().ToString();
    auto recording = std::make_unique<RecordingStore>(std::move(store).value());
    recording_ = recording.get();
    auto writer = StorageWriter::Start(std::move(recording), options);
    ASSERT_TRUE(writer.ok()) << writer.status().ToString();
    writer_ = std::move(writer).value();
  }
  std::string path() const { return dir_.File("semmap.db"); }

  WriteBatch Frames(int64_t first, int64_t count, int64_t session_id = 0) {
    WriteBatch batch;
    for (int64_t seq = first; seq < first + count; ++seq) {
      batch.frames.emplace_back(session_id == 0 ? session_.id : session_id, FramePose(seq));
    }
    return batch;
  }

  // Holds the writer thread inside a RunSync until Release(), so submissions pile up.
  void Stall() {
    std::promise<void> entered;
    std::future<void> entered_future = entered.get_future();
    stall_thread_ = std::thread([this, entered = std::move(entered)]() mutable {
      Status s = writer_->RunSync([&](MapStore&) {
        entered.set_value();
        release_.get_future().wait();
        return OkStatus();
      });
      EXPECT_TRUE(s.ok()) << s.ToString();
    });
    entered_future.wait();
  }
  void Release() {
    release_.set_value();
    stall_thread_.join();
  }

  TempDir dir_;
  std::unique_ptr<SqliteMapStore> reader_;
  SessionInfo session_;
  RecordingStore* recording_ = nullptr;  // owned by writer_
  std::unique_ptr<StorageWriter> writer_;
  std::promise<void> release_;
  std::thread stall_thread_;
};

TEST(StorageWriterStartTest, RejectsBadArguments) {
  EXPECT_EQ(StorageWriter::Start(nullptr, {}).status().code(), StatusCode::kInvalidArgument);
  TempDir dir;
  auto store = SqliteMapStore::Open(dir.File("a.db"), {});
  ASSERT_OK(store.status());
  StorageWriter::Options zero;
  zero.queue_capacity = 0;
  EXPECT_EQ(StorageWriter::Start(std::move(store).value(), zero).status().code(),
            StatusCode::kInvalidArgument);
}

TEST_F(StorageWriterTest, CallbackRunsAfterCommitWithKeyframeIds) {
  StartWriter();
  WriteBatch batch = Frames(0, 3);
  batch.keyframes = {Keyframe(session_.id, 0), Keyframe(session_.id, 2)};
  std::promise<void> called;
  Status seen_status = InternalError("not called");
  size_t visible_frames = 0;
  std::vector<int64_t> ids;
  std::vector<int64_t> visible_seqs;
  ASSERT_OK(writer_->Submit(std::move(batch), [&](const Status& s, const WriteResult& r) {
    seen_status = s;
    ids = r.keyframe_ids;
    // Another connection already sees the rows: the transaction has committed.
    visible_frames = reader_->GetTrajectory(session_.id, false)->size();
    for (int64_t id : ids) visible_seqs.push_back(reader_->GetKeyframe(id)->seq);
    called.set_value();
  }));
  called.get_future().wait();
  EXPECT_OK(seen_status);
  EXPECT_EQ(visible_frames, 3u);
  EXPECT_EQ(ids.size(), 2u);
  EXPECT_EQ(visible_seqs, (std::vector<int64_t>{0, 2}));
  EXPECT_OK(writer_->Stop());
}

TEST_F(StorageWriterTest, QueuedBatchesAreMergedIntoOneTransaction) {
  StartWriter();
  Stall();
  Outcomes outcomes;
  for (int i = 0; i < 5; ++i) {
    WriteBatch batch = Frames(i * 10, 2);
    batch.keyframes = {Keyframe(session_.id, i * 10), Keyframe(session_.id, i * 10 + 1)};
    if (i > 0) {
      // Links to the previous batch's keyframe by seq: resolved inside the merged transaction.
      LinkRecord link;
      link.map_id = session_.map_id;
      link.from_session_id = session_.id;
      link.from_seq = (i - 1) * 10 + 1;
      link.to_session_id = session_.id;
      link.to_seq = i * 10;
      batch.links.push_back(link);
    }
    ASSERT_OK(writer_->Submit(std::move(batch), outcomes.For(i)));
  }
  Release();
  ASSERT_OK(writer_->Stop());
  ASSERT_EQ(outcomes.size(), 5u);
  for (int i = 0; i < 5; ++i) {
    EXPECT_EQ(outcomes.calls[i].first, i);  // in submission order
    EXPECT_OK(outcomes.calls[i].second);
    ASSERT_EQ(outcomes.keyframe_ids[i].size(), 2u);
    // Each callback got its own slice of ids.
    EXPECT_EQ(reader_->GetKeyframe(outcomes.keyframe_ids[i][0])->seq, i * 10);
    EXPECT_EQ(reader_->GetKeyframe(outcomes.keyframe_ids[i][1])->seq, i * 10 + 1);
  }
  // One Write for all five batches (2 frames + 2 keyframes each, 4 links).
  EXPECT_EQ(recording_->write_sizes(), (std::vector<size_t>{5 * 4 + 4}));
  EXPECT_EQ(reader_->ListLinks(session_.map_id)->size(), 4u);
}

TEST_F(StorageWriterTest, MergingStopsAtMaxBatchItems) {
  StorageWriter::Options options;
  options.max_batch_items = 2;
  StartWriter(options);
  Stall();
  Outcomes outcomes;
  for (int i = 0; i < 5; ++i) ASSERT_OK(writer_->Submit(Frames(i, 1), outcomes.For(i)));
  Release();
  ASSERT_OK(writer_->Stop());
  EXPECT_EQ(recording_->write_sizes(), (std::vector<size_t>{2, 2, 1}));
  EXPECT_EQ(outcomes.size(), 5u);
  EXPECT_EQ(reader_->GetTrajectory(session_.id, false)->size(), 5u);
}

TEST_F(StorageWriterTest, BadBatchFailsAloneAfterMergedFailure) {
  StartWriter();
  Stall();
  Outcomes outcomes;
  ASSERT_OK(writer_->Submit(Frames(0, 2), outcomes.For(0)));
  ASSERT_OK(writer_->Submit(Frames(0, 1, /*session_id=*/99999), outcomes.For(1)));
  ASSERT_OK(writer_->Submit(Frames(2, 2), outcomes.For(2)));
  Release();
  outcomes.WaitFor(3);
  ASSERT_OK(writer_->Stop());  // the failure happened before Stop: reported to its callback only
  ASSERT_EQ(outcomes.size(), 3u);
  EXPECT_OK(outcomes.calls[0].second);
  EXPECT_EQ(outcomes.calls[1].second.code(), StatusCode::kNotFound);
  EXPECT_TRUE(outcomes.keyframe_ids[1].empty());
  EXPECT_OK(outcomes.calls[2].second);
  // Merged attempt, then each batch alone.
  EXPECT_EQ(recording_->write_sizes(), (std::vector<size_t>{5, 2, 1, 2}));
  EXPECT_EQ(reader_->GetTrajectory(session_.id, false)->size(), 4u);
}

TEST_F(StorageWriterTest, ObjectsSurviveTheRetryAfterAMergedFailure) {
  ObjectType type;
  type.label = "mug";
  ObjectView view;
  view.image = {"png", "img"};
  view.features_format = "f1";
  view.features = "feat";
  type.views = {view};
  const ObjectType mug = *reader_->CreateObjectType(type);
  const int64_t other_map = reader_->GetOrCreateMap("other")->id;
  auto instances = [&](double x, int n) {
    std::vector<ObjectInstance> list(static_cast<size_t>(n));
    for (ObjectInstance& o : list) {
      o.type_id = mug.id;
      o.position = Eigen::Vector3d(x, 0, 0);
    }
    return list;
  };
  StartWriter();
  Stall();
  Outcomes outcomes;
  WriteBatch first;
  first.keyframes = {Keyframe(session_.id, 0)};
  ObjectObservation o;
  o.map_id = session_.map_id;
  o.type_id = mug.id;
  o.session_id = session_.id;
  o.seq = 0;
  first.observations = {o};
  first.instances.emplace_back(session_.map_id, instances(1, 2));
  first.instances.emplace_back(other_map, instances(5, 1));
  ASSERT_OK(writer_->Submit(std::move(first), outcomes.For(0)));
  ASSERT_OK(writer_->Submit(Frames(0, 1, /*session_id=*/99999), outcomes.For(1)));
  WriteBatch third;
  third.observations = {o, o};                                     // the first batch's keyframe
  third.instances.emplace_back(session_.map_id, instances(2, 3));  // replaces the first's list
  ASSERT_OK(writer_->Submit(std::move(third), outcomes.For(2)));
  Release();
  outcomes.WaitFor(3);
  ASSERT_OK(writer_->Stop());
  ASSERT_EQ(outcomes.size(), 3u);
  EXPECT_OK(outcomes.calls[0].second);
  EXPECT_EQ(outcomes.calls[1].second.code(), StatusCode::kNotFound);
  EXPECT_OK(outcomes.calls[2].second);
  EXPECT_EQ(reader_->ListObjectObservations(session_.map_id)->size(), 3u);
  auto found = reader_->FindObjectInstances(session_.map_id, "");
  ASSERT_EQ(found->size(), 3u);
  EXPECT_EQ((*found)[0].position.x(), 2);
  EXPECT_EQ(reader_->FindObjectInstances(other_map, "")->size(), 1u);
}

TEST_F(StorageWriterTest, MapPointsSurviveTheRetryAfterAMergedFailure) {
  const int64_t other_map = reader_->GetOrCreateMap("other")->id;
  auto points = [&](int64_t first_id, int n) {
    std::vector<MapPointRecord> list(static_cast<size_t>(n));
    for (MapPointRecord& p : list) {
      p.point_id = first_id++;
      p.session_id = session_.id;
      p.observations = {{session_.id, 0, 1}};
    }
    return list;
  };
  StartWriter();
  Stall();
  Outcomes outcomes;
  WriteBatch first;
  first.keyframes = {Keyframe(session_.id, 0)};
  first.map_points.emplace_back(session_.map_id, points(1, 2));
  first.map_points.emplace_back(other_map, points(1, 1));  // observes another map's keyframe
  ASSERT_OK(writer_->Submit(std::move(first), outcomes.For(0)));
  ASSERT_OK(writer_->Submit(Frames(0, 1, /*session_id=*/99999), outcomes.For(1)));
  WriteBatch third;
  third.map_points.emplace_back(session_.map_id, points(10, 3));  // replaces the first's list
  ASSERT_OK(writer_->Submit(std::move(third), outcomes.For(2)));
  Release();
  outcomes.WaitFor(3);
  ASSERT_OK(writer_->Stop());
  ASSERT_EQ(outcomes.size(), 3u);
  EXPECT_OK(outcomes.calls[0].second);
  EXPECT_EQ(outcomes.calls[1].second.code(), StatusCode::kNotFound);
  EXPECT_OK(outcomes.calls[2].second);
  auto found = reader_->ListMapPoints(session_.map_id);
  ASSERT_OK(found.status());
  ASSERT_EQ(found->size(), 3u);
  EXPECT_EQ((*found)[0].point_id, 10);
  EXPECT_EQ(*reader_->connection().QueryInt64("SELECT COUNT(*) FROM map_points WHERE map_id = " +
                                              std::to_string(other_map)),
            1);
}

TEST_F(StorageWriterTest, StopDrainsEverythingAndCheckpoints) {
  StorageWriter::Options options;
  options.queue_capacity = 4;  // submissions block and wait for room
  StartWriter(options);
  Outcomes outcomes;
  constexpr int kBatches = 60;
  for (int i = 0; i < kBatches; ++i) ASSERT_OK(writer_->Submit(Frames(i, 1), outcomes.For(i)));
  ASSERT_OK(writer_->Stop());
  ASSERT_EQ(outcomes.size(), static_cast<size_t>(kBatches));
  for (const auto& [tag, status] : outcomes.calls) EXPECT_OK(status);
  EXPECT_EQ(recording_->checkpoints.load(), 1);
  EXPECT_OK(writer_->Stop());  // idempotent
  EXPECT_EQ(recording_->checkpoints.load(), 1);
  reader_.reset();
  auto reopened = SqliteMapStore::Open(path(), {});
  ASSERT_OK(reopened.status());
  EXPECT_EQ((*reopened)->GetTrajectory(session_.id, false)->size(), static_cast<size_t>(kBatches));
}

TEST_F(StorageWriterTest, SubmitAndRunSyncAfterStopAreUnavailable) {
  StartWriter();
  ASSERT_OK(writer_->Stop());
  bool called = false;
  Status submitted =
      writer_->Submit(Frames(0, 1), [&](const Status&, const WriteResult&) { called = true; });
  EXPECT_EQ(submitted.code(), StatusCode::kUnavailable);
  EXPECT_EQ(writer_->RunSync([](MapStore&) { return OkStatus(); }).code(),
            StatusCode::kUnavailable);
  EXPECT_FALSE(called);
  EXPECT_TRUE(reader_->GetTrajectory(session_.id, false)->empty());
}

TEST_F(StorageWriterTest, RunSyncSeesEverythingSubmittedBefore) {
  StartWriter();
  for (int i = 0; i < 20; ++i) ASSERT_OK(writer_->Submit(Frames(i, 1), nullptr));
  size_t seen = 0;
  ASSERT_OK(writer_->RunSync([&](MapStore& store) -> Status {
    SEMMAP_ASSIGN_OR_RETURN(std::vector<TrajectoryPose> poses,
                            store.GetTrajectory(session_.id, false));
    seen = poses.size();
    return OkStatus();
  }));
  EXPECT_EQ(seen, 20u);
  // fn's status comes back as is.
  Status status = writer_->RunSync(
      [](MapStore& store) { return store.CreateSession(NewSession(1, "s")).status(); });
  EXPECT_EQ(status.code(), StatusCode::kAlreadyExists);
}

TEST_F(StorageWriterTest, SyncCallBetweenBatchesKeepsOrder) {
  StartWriter();
  Stall();
  Outcomes outcomes;
  ASSERT_OK(writer_->Submit(Frames(0, 1), outcomes.For(0)));
  std::atomic<size_t> seen{0};
  std::thread sync([&] {
    Status s = writer_->RunSync([&](MapStore& store) -> Status {
      seen = store.GetTrajectory(session_.id, false)->size();
      return OkStatus();
    });
    EXPECT_OK(s);
  });
  // Batch 1 goes in only once the sync call is queued behind batch 0.
  while (writer_->queue_depth() < 2) std::this_thread::sleep_for(std::chrono::milliseconds(1));
  ASSERT_OK(writer_->Submit(Frames(1, 1), outcomes.For(1)));
  Release();
  sync.join();
  ASSERT_OK(writer_->Stop());
  EXPECT_EQ(seen.load(), 1u);  // batch 0 committed, batch 1 not yet
  EXPECT_EQ(recording_->write_sizes(), (std::vector<size_t>{1, 1}));  // not merged across it
}

TEST_F(StorageWriterTest, SubmitBlocksWhileTheQueueIsFull) {
  StorageWriter::Options options;
  options.queue_capacity = 1;
  StartWriter(options);
  Stall();
  ASSERT_OK(writer_->Submit(Frames(0, 1), nullptr));  // fills the queue
  std::atomic<bool> returned{false};
  std::thread blocked([&] {
    EXPECT_OK(writer_->Submit(Frames(1, 1), nullptr));
    returned = true;
  });
  std::this_thread::sleep_for(std::chrono::milliseconds(100));
  EXPECT_FALSE(returned.load());
  Release();
  blocked.join();
  EXPECT_TRUE(returned.load());
  ASSERT_OK(writer_->Stop());
  EXPECT_EQ(reader_->GetTrajectory(session_.id, false)->size(), 2u);
}

TEST_F(StorageWriterTest, StopReportsAFailedWriteItDrained) {
  StartWriter();
  Stall();
  Outcomes outcomes;
  ASSERT_OK(writer_->Submit(Frames(0, 1, /*session_id=*/424242), outcomes.For(0)));
  std::promise<Status> stopped;
  std::thread stopper([&] { stopped.set_value(writer_->Stop()); });
  // Stop shuts the queue before it waits for the thread; wait for that before releasing.
  while (writer_->Submit(WriteBatch{}, nullptr).ok()) {
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
  Release();
  stopper.join();
  Status status = stopped.get_future().get();
  EXPECT_EQ(status.code(), StatusCode::kNotFound) << status.ToString();
  EXPECT_NE(status.message().find("session id 424242"), std::string::npos);
  ASSERT_EQ(outcomes.size(), 1u);
  EXPECT_EQ(outcomes.calls[0].second.code(), StatusCode::kNotFound);
  EXPECT_EQ(writer_->Stop().code(), StatusCode::kNotFound);  // the same answer again
}

TEST_F(StorageWriterTest, ReentrantCallsFromTheWriterThreadAreRefused) {
  StartWriter();
  Status inner_submit;
  Status inner_sync;
  Status inner_stop;
  ASSERT_OK(writer_->RunSync([&](MapStore&) {
    inner_submit = writer_->Submit(WriteBatch{}, nullptr);
    inner_sync = writer_->RunSync([](MapStore&) { return OkStatus(); });
    inner_stop = writer_->Stop();
    return OkStatus();
  }));
  EXPECT_EQ(inner_submit.code(), StatusCode::kFailedPrecondition);
  EXPECT_EQ(inner_sync.code(), StatusCode::kFailedPrecondition);
  EXPECT_EQ(inner_stop.code(), StatusCode::kFailedPrecondition);
  EXPECT_OK(writer_->Stop());
}

TEST_F(StorageWriterTest, DestructorStopsAndDrains) {
  StartWriter();
  Outcomes outcomes;
  for (int i = 0; i < 10; ++i) ASSERT_OK(writer_->Submit(Frames(i, 1), outcomes.For(i)));
  writer_.reset();
  EXPECT_EQ(outcomes.size(), 10u);
  EXPECT_EQ(reader_->GetTrajectory(session_.id, false)->size(), 10u);
}

}  // namespace
}  // namespace semmap
