#include "core/objects/object_mapper.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <set>
#include <string>

#include "common/logging.h"
#include "common/thread_launcher.h"
#include "common/thread_priority.h"
#include "common/time_util.h"
#include "core/recognition/keyframe_recognition.h"

namespace semmap {

using Clock = std::chrono::steady_clock;

Status ObjectMapperOptions::Validate() const {
  SEMMAP_RETURN_IF_ERROR(fusion.Validate().WithContext("object fusion"));
  if (queue_capacity < 1 || queue_capacity > 100000) {
    return InvalidArgumentError("object mapper queue capacity must be in [1, 100000]");
  }
  return OkStatus();
}

StatusOr<std::unique_ptr<ObjectMapper>> ObjectMapper::Start(
    int64_t map_id, ObjectMapperOptions options, const ObjectCatalog* catalog,
    StorageWriter* writer, StoreRestore restore, StageConfig stage) {
  SEMMAP_RETURN_IF_ERROR(options.Validate());
  if (catalog == nullptr || writer == nullptr) {
    return InvalidArgumentError("the object mapper needs a catalog and a storage writer");
  }
  stage.name = "objects of map " + std::to_string(map_id);
  stage.thread_name = "object-mapper";
  stage.queue_capacity = options.queue_capacity;
  std::unique_ptr<ObjectMapper> mapper(
      new ObjectMapper(map_id, options, catalog, writer, std::move(restore), std::move(stage)));
  SEMMAP_RETURN_IF_ERROR(mapper->PipelineStage::Start());
  return mapper;
}

ObjectMapper::ObjectMapper(int64_t map_id, ObjectMapperOptions options,
                           const ObjectCatalog* catalog, StorageWriter* writer,
                           StoreRestore restore, StageConfig stage)
    : PipelineStage(std::move(stage)),
      map_id_(map_id),
      options_(options),
      catalog_(catalog),
      writer_(writer),
      restore_(std::move(restore)),
      writes_(writer, "objects") {}

ObjectMapper::~ObjectMapper() { Stop(); }

Status ObjectMapper::AddKeyframe(int64_t session_id, int64_t seq, int64_t stamp_ns,
                                 std::shared_ptr<const FrameFeatures> features,
                                 const CameraCalibration& camera) {
  if (!features) return InvalidArgumentError("object mapper: keyframe without features");
  return Submit(KeyframeItem{std::move(features), session_id, seq, stamp_ns, camera, {}, {}});
}

Status ObjectMapper::AddKeyframeImages(int64_t session_id, int64_t seq, int64_t stamp_ns,
                                       cv::Mat colour, DecodedDepth depth,
                                       const CameraCalibration& camera) {
  return Submit(KeyframeItem{nullptr, session_id, seq, stamp_ns, camera, std::move(colour),
                             std::move(depth)});
}

Status ObjectMapper::EndSession(int64_t session_id) { return Submit(SessionEnd{session_id}); }

Status ObjectMapper::SetKeyframePoses(std::vector<KeyframePose> poses, bool /*correction*/) {
  return Submit(PoseUpdate{std::move(poses)});
}

ObjectMapperStats ObjectMapper::stats() const {
  const StageMetrics stage = metrics();
  std::lock_guard lock(mutex_);
  ObjectMapperStats out = stats_;
  out.queue_high_water = stage.queue_high_water;
  out.recognise_ms = recognise_ms_.Summarize();
  out.fuse_ms = fuse_ms_.Summarize();
  return out;
}

void ObjectMapper::OnStart() {
  if (restore_.enabled) Restore();
}

void ObjectMapper::Handle(object_mapper_internal::Event& event) {
  std::visit([this](auto& e) { Handle(e); }, event);
}

std::optional<ObjectMapper::Clock::time_point> ObjectMapper::OnIdle() {
  if (dirty_) FuseAndWrite();  // idle: the instances catch up
  return std::nullopt;
}

Status ObjectMapper::OnFlush() {
  if (dirty_) FuseAndWrite();
  return writes_.WaitAndTakeError();
}

void ObjectMapper::OnStop() {
  // Every session's last keyframe is decided, and the instances fused once more.
  std::vector<int64_t> open;
  for (const auto& [session_id, recent] : recent_) {
    if (!recent.empty()) open.push_back(session_id);
  }
  for (const int64_t session_id : open) Handle(SessionEnd{session_id});
  if (dirty_) FuseAndWrite();
  writes_.Wait();  // Stop() returns with everything committed
}

void ObjectMapper::Restore() {
  std::vector<ObjectObservation> stored;
  std::map<Key, Eigen::Isometry3d> poses;
  const Status status = ReadForRestore(restore_, *writer_, [&](MapStore& store) -> Status {
    SEMMAP_ASSIGN_OR_RETURN(stored, store.ListObjectObservations(map_id_));
    if (stored.empty()) return OkStatus();
    std::set<int64_t> sessions;
    for (const ObjectObservation& o : stored) sessions.insert(o.session_id);
    for (const int64_t session_id : sessions) {
      SEMMAP_ASSIGN_OR_RETURN(std::vector<KeyframeRecord> keyframes,
                              store.ListKeyframes(session_id, /*with_images=*/false));
      for (const KeyframeRecord& kf : keyframes) poses[{session_id, kf.seq}] = kf.T_world_camera;
    }
    return OkStatus();
  });
  if (!status.ok()) {
    RecordError(status.WithContext("restoring observations"));
    return;
  }
  observations_ = std::move(stored);
  // Poses the back end sent already are newer than the stored ones.
  for (auto& [key, T] : poses) poses_.emplace(key, T);
  // The stored instances may predate a removal or a correction: fuse them afresh once.
  dirty_ = !observations_.empty();
  std::lock_guard lock(mutex_);
  stats_.restored_observations = observations_.size();
}

void ObjectMapper::Handle(KeyframeItem& item) {
  if (!item.features) {
    if (!options_.enabled || catalog_->ModelsFor(map_id_)->models.empty()) return;
    auto extractor = extractors_.find(item.session_id);
    if (extractor == extractors_.end()) {
      StatusOr<FeatureExtractor> created = FeatureExtractor::Create({}, item.camera);
      if (!created.ok()) {
        RecordError(created.status().WithContext("keyframe features"));
        return;
      }
      extractor = extractors_.emplace(item.session_id, std::move(created).value()).first;
    }
    StatusOr<FrameFeatures> features =
        extractor->second.Extract(item.colour, item.depth.raw, item.depth.depth_scale);
    if (!features.ok()) {
      RecordError(features.status().WithContext("keyframe seq " + std::to_string(item.seq)));
      return;
    }
    item.features = std::make_shared<const FrameFeatures>(std::move(features).value());
    item.colour.release();  // only the features are kept for the neighbours
    item.depth = {};
  }
  std::deque<KeyframeItem>& recent = recent_[item.session_id];
  recent.push_back(std::move(item));
  // The one before the newest now has both neighbours.
  if (recent.size() >= 2) {
    const KeyframeItem* before = recent.size() >= 3 ? &recent[recent.size() - 3] : nullptr;
    Recognise(recent[recent.size() - 2], before, &recent.back());
  }
  while (recent.size() > 2) recent.pop_front();
}

void ObjectMapper::Handle(const SessionEnd& end) {
  auto it = recent_.find(end.session_id);
  if (it == recent_.end() || it->second.empty()) return;
  std::deque<KeyframeItem>& recent = it->second;
  const KeyframeItem* before = recent.size() >= 2 ? &recent[recent.size() - 2] : nullptr;
  Recognise(recent.back(), before, nullptr);
  recent_.erase(it);
  extractors_.erase(end.session_id);
}

void ObjectMapper::Handle(const PoseUpdate& update) {
  for (const KeyframePose& p : update.poses) {
    poses_[{p.session_id, p.seq}] = p.T_world_keyframe;
  }
  // Only poses of keyframes with observations move instances.
  if (!dirty_) {
    for (const KeyframePose& p : update.poses) {
      for (const ObjectObservation& o : observations_) {
        if (o.session_id == p.session_id && o.seq == p.seq) {
          dirty_ = true;
          break;
        }
      }
      if (dirty_) break;
    }
  }
}

void ObjectMapper::Recognise(const KeyframeItem& target, const KeyframeItem* before,
                             const KeyframeItem* after) {
  if (!options_.enabled) return;
  const std::shared_ptr<const ObjectModelSet> models = catalog_->ModelsFor(map_id_);
  if (models->models.empty()) return;
  const Clock::time_point t0 = Clock::now();
  std::vector<const FrameFeatures*> neighbours;
  if (before) neighbours.push_back(before->features.get());
  if (after) neighbours.push_back(after->features.get());
  StatusOr<KeyframeRecognition> result =
      RecogniseKeyframe(*target.features, target.camera, neighbours, models->models,
                        catalog_->options(), options_.apply_xi);
  if (!result.ok()) {
    RecordError(result.status().WithContext("keyframe seq " + std::to_string(target.seq)));
    return;
  }
  WriteBatch batch;
  uint64_t rejected = 0;
  for (const RecognisedObject& found : result->found) {
    if (!found.xi.accepted()) {
      ++rejected;
      continue;
    }
    ObjectObservation o = ToObservation(found.detection, found.xi.xi);
    o.map_id = map_id_;
    o.session_id = target.session_id;
    o.seq = target.seq;
    o.stamp_ns = target.stamp_ns;
    batch.observations.push_back(o);
    observations_.push_back(std::move(o));
  }
  const size_t accepted = batch.observations.size();
  if (accepted > 0) {
    dirty_ = true;
    writes_.Submit(std::move(batch));
  }
  std::lock_guard lock(mutex_);
  ++stats_.keyframes_searched;
  stats_.detections += result->found.size();
  stats_.rejected_by_xi += rejected;
  stats_.observations += accepted;
  stats_.models = models->models.size();
  recognise_ms_.Add(MillisecondsSince(t0));
}

void ObjectMapper::FuseAndWrite() {
  const Clock::time_point t0 = Clock::now();
  dirty_ = false;
  // Types removed since are dropped (the store removed their rows).
  std::erase_if(observations_,
                [&](const ObjectObservation& o) { return !catalog_->Contains(o.type_id); });
  std::vector<WorldObjectObservation> world;
  world.reserve(observations_.size());
  for (const ObjectObservation& o : observations_) {
    const auto pose = poses_.find({o.session_id, o.seq});
    if (pose == poses_.end()) continue;  // placed once the back end says where it is
    world.push_back(ObservationInWorld(o, pose->second));
    world.back().map_id = map_id_;
  }
  StatusOr<std::vector<ObjectInstance>> instances = FuseObservations(world, options_.fusion);
  if (!instances.ok()) {
    RecordError(instances.status());
    return;
  }
  for (ObjectInstance& instance : *instances) instance.map_id = map_id_;
  const size_t count = instances->size();
  WriteBatch batch;
  batch.instances.emplace_back(map_id_, std::move(instances).value());
  writes_.Submit(std::move(batch));
  std::lock_guard lock(mutex_);
  ++stats_.fusions;
  stats_.instances = count;
  fuse_ms_.Add(MillisecondsSince(t0));
}

}  // namespace semmap
