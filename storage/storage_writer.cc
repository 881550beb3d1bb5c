#include "storage/storage_writer.h"

#include <algorithm>
#include <iterator>
#include <optional>
#include <string>
#include <utility>

#include "common/thread_priority.h"

namespace semmap {
namespace {

// How many rows of each kind one batch contributed to a merged batch.
struct BatchShape {
  size_t frames = 0, keyframes = 0, links = 0, blobs = 0, pose_updates = 0, culled_keyframes = 0,
         observations = 0;
  std::vector<int64_t> instance_maps;  // maps whose instances the batch replaces
  std::vector<int64_t> point_maps;     // maps whose map points the batch replaces
};

template <typename T>
std::vector<int64_t> MapsOf(const std::vector<std::pair<int64_t, std::vector<T>>>& replacements) {
  std::vector<int64_t> maps;
  maps.reserve(replacements.size());
  for (const auto& entry : replacements) maps.push_back(entry.first);
  return maps;
}

BatchShape ShapeOf(const WriteBatch& b) {
  BatchShape shape;
  shape.frames = b.frames.size();
  shape.keyframes = b.keyframes.size();
  shape.links = b.links.size();
  shape.blobs = b.blobs.size();
  shape.pose_updates = b.pose_updates.size();
  shape.culled_keyframes = b.culled_keyframes.size();
  shape.observations = b.observations.size();
  shape.instance_maps = MapsOf(b.instances);
  shape.point_maps = MapsOf(b.map_points);
  return shape;
}

template <typename T>
std::vector<T> TakeRange(std::vector<T>& from, size_t& offset, size_t count) {
  auto first = from.begin() + static_cast<std::ptrdiff_t>(offset);
  offset += count;
  return std::vector<T>(std::make_move_iterator(first),
                        std::make_move_iterator(first + static_cast<std::ptrdiff_t>(count)));
}

// Append kept one replacement per map, the latest: it goes back to the last batch that
// replaced that map (the earlier batches' lists were superseded and are not retried).
template <typename T>
void ReturnReplacements(std::vector<std::pair<int64_t, std::vector<T>>>&& merged,
                        const std::vector<BatchShape>& shapes,
                        std::vector<int64_t> BatchShape::*maps_of,
                        std::vector<std::pair<int64_t, std::vector<T>>> WriteBatch::*rows_of,
                        std::vector<WriteBatch>& batches) {
  for (auto& entry : merged) {
    for (size_t i = shapes.size(); i-- > 0;) {
      const std::vector<int64_t>& maps = shapes[i].*maps_of;
      if (std::find(maps.begin(), maps.end(), entry.first) != maps.end()) {
        (batches[i].*rows_of).push_back(std::move(entry));
        break;
      }
    }
  }
}

// Undoes WriteBatch::Append: gives every batch its own rows back, in order.
std::vector<WriteBatch> Split(WriteBatch&& merged, const std::vector<BatchShape>& shapes) {
  std::vector<WriteBatch> batches;
  BatchShape offset;
  for (const BatchShape& shape : shapes) {
    WriteBatch& b = batches.emplace_back();
    b.frames = TakeRange(merged.frames, offset.frames, shape.frames);
    b.keyframes = TakeRange(merged.keyframes, offset.keyframes, shape.keyframes);
    b.links = TakeRange(merged.links, offset.links, shape.links);
    b.blobs = TakeRange(merged.blobs, offset.blobs, shape.blobs);
    b.pose_updates = TakeRange(merged.pose_updates, offset.pose_updates, shape.pose_updates);
    b.culled_keyframes =
        TakeRange(merged.culled_keyframes, offset.culled_keyframes, shape.culled_keyframes);
    b.observations = TakeRange(merged.observations, offset.observations, shape.observations);
  }
  ReturnReplacements(std::move(merged.instances), shapes, &BatchShape::instance_maps,
                     &WriteBatch::instances, batches);
  ReturnReplacements(std::move(merged.map_points), shapes, &BatchShape::point_maps,
                     &WriteBatch::map_points, batches);
  return batches;
}

Status CalledFromWriter(const char* what) {
  return FailedPreconditionError(std::string(what) +
                                 " called on the storage writer thread (it would deadlock)");
}

}  // namespace

Status StorageWriter::Options::Validate() const {
  if (queue_capacity == 0) return InvalidArgumentError("storage queue_capacity must be >= 1");
  if (max_batch_items == 0) return InvalidArgumentError("storage max_batch_items must be >= 1");
  return OkStatus();
}

StatusOr<std::unique_ptr<StorageWriter>> StorageWriter::Start(std::unique_ptr<MapStore> store,
                                                              Options options) {
  if (store == nullptr) return InvalidArgumentError("storage writer needs a store");
  SEMMAP_RETURN_IF_ERROR(options.Validate());
  std::unique_ptr<StorageWriter> writer(new StorageWriter(std::move(store), options));
  {
    MutexLock lock(writer->stop_mutex_);
    writer->thread_ = std::thread([w = writer.get()] {
      NameCurrentThread("sqlite-writer");
      w->Run();
    });
    // Nothing reaches the thread before Start returns, so it never reads this id too early.
    writer->writer_id_ = writer->thread_.get_id();
  }
  return writer;
}

StorageWriter::StorageWriter(std::unique_ptr<MapStore> store, Options options)
    : store_(std::move(store)), options_(options), queue_(options.queue_capacity) {}

StorageWriter::~StorageWriter() {
  Status ignored = Stop();  // a destructor cannot report; call Stop() first to see errors
  (void)ignored;
}

Status StorageWriter::Submit(WriteBatch batch, Done done) {
  if (OnWriterThread()) return CalledFromWriter("StorageWriter::Submit");
  if (!queue_.Push(PendingWrite{std::move(batch), std::move(done)})) {
    return UnavailableError("storage writer is stopped");
  }
  return OkStatus();
}

Status StorageWriter::RunSync(std::function<Status(MapStore&)> fn) {
  if (OnWriterThread()) return CalledFromWriter("StorageWriter::RunSync");
  std::promise<Status> promise;
  std::future<Status> result = promise.get_future();
  if (!queue_.Push(SyncCall{std::move(fn), std::move(promise)})) {
    return UnavailableError("storage writer is stopped");
  }
  // The thread drains every queued item before it exits, so the promise is always kept.
  return result.get();
}

Status StorageWriter::Stop() {
  if (OnWriterThread()) return CalledFromWriter("StorageWriter::Stop");
  MutexLock lock(stop_mutex_);
  if (stopped_) return stop_status_;
  queue_.Shutdown();  // later Submit/RunSync fail; the thread drains what is queued
  if (thread_.joinable()) thread_.join();
  stopped_ = true;
  stop_status_ = drain_status_;
  return stop_status_;
}

void StorageWriter::Run() {
  std::optional<Item> next;
  for (;;) {
    if (!next) next = queue_.Pop();
    if (!next) break;  // shut down and drained
    Item item = std::move(*next);
    next.reset();
    if (auto* call = std::get_if<SyncCall>(&item)) {
      call->result.set_value(call->fn(*store_));
      continue;
    }
    // Merge whatever else is already waiting: one commit (one fsync) for many batches.
    std::vector<PendingWrite> group;
    group.push_back(std::move(std::get<PendingWrite>(item)));
    while (group.size() < options_.max_batch_items) {
      std::optional<Item> more = queue_.TryPop();
      if (!more) break;
      if (std::holds_alternative<SyncCall>(*more)) {
        next = std::move(more);  // runs after this group commits: submission order is kept
        break;
      }
      group.push_back(std::move(std::get<PendingWrite>(*more)));
    }
    CommitGroup(group);
  }
  Status checkpoint = store_->Checkpoint();
  if (drain_status_.ok() && !checkpoint.ok()) drain_status_ = checkpoint.WithContext("checkpoint");
}

void StorageWriter::CommitGroup(std::vector<PendingWrite>& group) {
  if (group.size() == 1) {
    StatusOr<WriteResult> result = store_->Write(group.front().batch);
    Finish(group.front(), result.status(), result.ok() ? std::move(result).value() : WriteResult{});
    return;
  }
  std::vector<BatchShape> shapes;
  WriteBatch merged;
  for (PendingWrite& write : group) {
    shapes.push_back(ShapeOf(write.batch));
    merged.Append(std::move(write.batch));
  }
  StatusOr<WriteResult> result = store_->Write(merged);
  if (result.ok()) {
    const std::vector<int64_t>& ids = result->keyframe_ids;
    size_t offset = 0;
    for (size_t i = 0; i < group.size(); ++i) {
      WriteResult own;
      own.keyframe_ids.assign(
          ids.begin() + static_cast<std::ptrdiff_t>(offset),
          ids.begin() + static_cast<std::ptrdiff_t>(offset + shapes[i].keyframes));
      offset += shapes[i].keyframes;
      Finish(group[i], OkStatus(), own);
    }
    return;
  }
  // The merged transaction rolled back as a whole: retry batch by batch, in order, so only the
  // bad ones fail (and later batches still see the keyframes of earlier good ones).
  std::vector<WriteBatch> batches = Split(std::move(merged), shapes);
  for (size_t i = 0; i < group.size(); ++i) {
    StatusOr<WriteResult> alone = store_->Write(batches[i]);
    Finish(group[i], alone.status(), alone.ok() ? std::move(alone).value() : WriteResult{});
  }
}

void StorageWriter::Finish(PendingWrite& write, const Status& status, const WriteResult& result) {
  if (!status.ok() && drain_status_.ok() && queue_.is_shutdown()) {
    drain_status_ = status.WithContext("storage write during shutdown");
  }
  if (write.done) write.done(status, result);
}

}  // namespace semmap
