#include "core/mapping/map_layer_builder.h"

#include <cmath>
#include <cstdio>
#include <string>

#include "common/logging.h"
#include "common/memory_trim.h"
#include "common/thread_launcher.h"
#include "common/thread_priority.h"
#include "common/time_util.h"
#include "core/mapping/layer_frame.h"
#include "core/mapping/stored_keyframe_clouds.h"

namespace semmap {
namespace {

using Clock = std::chrono::steady_clock;

bool MovedBeyond(const Eigen::Isometry3d& a, const Eigen::Isometry3d& b, double max_translation_m,
                 double max_rotation_rad) {
  const Eigen::Isometry3d delta = a.inverse() * b;
  return delta.translation().norm() > max_translation_m ||
         Eigen::AngleAxisd(delta.rotation()).angle() > max_rotation_rad;
}

// A stored keyframe whose cloud cannot be read back (its session removed, its images damaged):
// left out of the layers rather than failing them.
bool Unreadable(const Status& status) {
  return status.code() == StatusCode::kNotFound || status.code() == StatusCode::kDataLoss;
}

int64_t NowUnixNs() {
  return std::chrono::duration_cast<std::chrono::nanoseconds>(
             std::chrono::system_clock::now().time_since_epoch())
      .count();
}

}  // namespace

Status MapLayerOptions::Validate() const {
  SEMMAP_RETURN_IF_ERROR(occupancy.Validate().WithContext("map layers"));
  SEMMAP_RETURN_IF_ERROR(cloud.Validate().WithContext("map layers"));
  if (queue_capacity < 1 || queue_capacity > 100000) {
    return InvalidArgumentError("map layers: queue capacity must be in [1, 100000]");
  }
  if (!std::isfinite(persist_interval_s) || persist_interval_s < 0 || persist_interval_s > 3600) {
    return InvalidArgumentError("map layers: persist interval must be in [0, 3600] s");
  }
  if (!(rebuild_min_translation_m >= 0) || !(rebuild_min_rotation_rad >= 0) ||
      !std::isfinite(rebuild_min_translation_m) || !std::isfinite(rebuild_min_rotation_rad)) {
    return InvalidArgumentError("map layers: rebuild thresholds must be finite and >= 0");
  }
  if (keyframe_cloud_budget_bytes > (size_t{1} << 40)) {
    return InvalidArgumentError("map layers: keyframe cloud budget must be at most 1 TiB");
  }
  return OkStatus();
}

StatusOr<std::unique_ptr<MapLayerBuilder>> MapLayerBuilder::Start(
    int64_t map_id, std::string map_name, MapLayerOptions options, StorageWriter* writer,
    StoreRestore restore, StageConfig stage) {
  SEMMAP_RETURN_IF_ERROR(options.Validate());
  if (writer == nullptr) return InvalidArgumentError("map layers need a storage writer");
  SEMMAP_ASSIGN_OR_RETURN(OccupancyMap occupancy, OccupancyMap::Create(options.occupancy));
  SEMMAP_ASSIGN_OR_RETURN(IncrementalCloud cloud, IncrementalCloud::Create(options.cloud));
  stage.name = "map '" + map_name + "' layers";
  stage.thread_name = "map-layers";
  stage.queue_capacity = options.queue_capacity;
  std::unique_ptr<MapLayerBuilder> builder(
      new MapLayerBuilder(map_id, std::move(map_name), options, writer, std::move(occupancy),
                          std::move(cloud), std::move(restore), std::move(stage)));
  SEMMAP_RETURN_IF_ERROR(builder->PipelineStage::Start());
  return builder;
}

MapLayerBuilder::MapLayerBuilder(int64_t map_id, std::string map_name, MapLayerOptions options,
                                 StorageWriter* writer, OccupancyMap occupancy,
                                 IncrementalCloud cloud, StoreRestore restore, StageConfig stage)
    : PipelineStage(std::move(stage)),
      map_id_(map_id),
      map_name_(std::move(map_name)),
      options_(options),
      writer_(writer),
      restore_(std::move(restore)),
      cache_(options.keyframe_cloud_budget_bytes, options.occupancy,
             [this](const std::function<Status(MapStore&)>& read) { return ReadStore(read); }),
      occupancy_(std::move(occupancy)),
      cloud_(std::move(cloud)),
      last_persist_(Clock::now()),
      writes_(writer, "map layers") {}

MapLayerBuilder::~MapLayerBuilder() { Stop(); }

Status MapLayerBuilder::AddKeyframeImages(int64_t session_id, int64_t seq, DecodedDepth depth,
                                          cv::Mat colour, const CameraCalibration& camera) {
  return Submit(KeyframeImages{session_id, seq, std::move(depth), std::move(colour), camera});
}

Status MapLayerBuilder::SetKeyframePoses(std::vector<KeyframePose> poses, bool correction) {
  return Submit(PoseUpdate{std::move(poses), correction});
}

MapLayerStats MapLayerBuilder::stats() const {
  const StageMetrics stage = metrics();
  std::lock_guard lock(mutex_);
  MapLayerStats out = stats_;
  out.queue_high_water = stage.queue_high_water;
  out.insert_ms = insert_ms_.Summarize();
  out.rebuild_ms = rebuild_ms_.Summarize();
  out.persist_ms = persist_ms_.Summarize();
  return out;
}

void MapLayerBuilder::OnStart() {
  if (restore_.enabled) Restore();
}

void MapLayerBuilder::Handle(map_layer_internal::Event& event) {
  std::visit([this](auto& e) { Handle(e); }, event);
}

std::optional<MapLayerBuilder::Clock::time_point> MapLayerBuilder::OnIdle() {
  // Catch up on the deferred work; blobs are written at most every persist_interval_s while
  // keyframes keep arriving, so wake up for the next persist when the layers changed.
  const auto interval = std::chrono::duration_cast<Clock::duration>(
      std::chrono::duration<double>(options_.persist_interval_s));
  if (rebuild_needed_) Rebuild();
  if (dirty_ && Clock::now() >= last_persist_ + interval) Persist();
  if (!dirty_) return std::nullopt;
  return last_persist_ + interval;
}

Status MapLayerBuilder::OnFlush() {
  if (rebuild_needed_) Rebuild();
  if (dirty_) Persist();
  return writes_.WaitAndTakeError();
}

void MapLayerBuilder::OnStop() {
  if (rebuild_needed_) Rebuild();
  if (dirty_) Persist();
  writes_.Wait();  // Stop() returns with the blobs committed
}

Status MapLayerBuilder::ReadStore(const std::function<Status(MapStore&)>& read) {
  if (!restore_.open_reader) return writer_->RunSync(read);
  if (!reader_) {
    SEMMAP_ASSIGN_OR_RETURN(reader_, restore_.open_reader());
  }
  return read(*reader_);
}

void MapLayerBuilder::Restore() {
  // Damage in what is stored (a keyframe image, the origin) is logged and worked around: it must
  // not fail the sessions that stream into the map afterwards. The keyframes' images are read
  // one at a time by the rebuild that follows (a damaged one is left out there).
  StoredKeyframeRefs stored;
  const Status status = ReadStore([&](MapStore& store) -> Status {
    StatusOr<std::optional<Eigen::Vector3d>> origin = ReadLayerOrigin(store, map_id_, map_name_);
    if (!origin.ok() && origin.status().code() == StatusCode::kDataLoss) {
      LogWarning("map '{}' layers: {}; using the first keyframe's origin", map_name_,
                 origin.status().ToString());
      origin = FirstKeyframeLayerOrigin(store, map_name_);
    }
    SEMMAP_ASSIGN_OR_RETURN(origin_, std::move(origin));
    SEMMAP_ASSIGN_OR_RETURN(stored, ListStoredKeyframes(store, map_name_));
    return OkStatus();
  });
  if (!status.ok()) {
    RecordError(status.WithContext("restoring from stored keyframes"));
    return;
  }
  for (const StoredKeyframeRef& kf : stored.keyframes) {
    const Key key{kf.session_id, kf.seq};
    entries_[key].T_world_keyframe = kf.T_world_keyframe;
    cache_.PutStored(key, kf.keyframe_id, stored.cameras.at(kf.session_id));
  }
  if (stored.keyframes.empty()) return;
  rebuild_needed_ = true;
  std::lock_guard lock(mutex_);
  stats_.restored_keyframes = stored.keyframes.size();
}

void MapLayerBuilder::Handle(KeyframeImages& images) {
  const Clock::time_point t0 = Clock::now();
  StatusOr<KeyframeCloud> cloud =
      MakeKeyframeCloud(images.depth, images.colour, images.camera, options_.occupancy);
  if (!cloud.ok()) {
    RecordError(cloud.status().WithContext("keyframe seq " + std::to_string(images.seq)));
    return;
  }
  const Key key{images.session_id, images.seq};
  Entry& entry = entries_[key];
  // A keyframe seen again (restored, then re-sent) replaces its cloud: the tree and the cloud
  // layer need a rebuild (which takes the old points out of the cloud layer too).
  if (entry.inserted || entry.T_layer_in_cloud) rebuild_needed_ = true;
  cache_.Put(key, std::make_shared<const KeyframeCloud>(std::move(cloud).value()), images.camera);
  entry.inserted = false;
  entry.T_layer_in_cloud.reset();
  InsertIfReady(key, entry);
  if (entry.inserted) {
    std::lock_guard lock(mutex_);
    insert_ms_.Add(MillisecondsSince(t0));
  }
}

void MapLayerBuilder::Handle(const PoseUpdate& update) {
  for (const KeyframePose& pose : update.poses) {
    const Key key{pose.session_id, pose.seq};
    Entry& entry = entries_[key];
    if (entry.inserted &&
        MovedBeyond(entry.T_world_built, pose.T_world_keyframe, options_.rebuild_min_translation_m,
                    options_.rebuild_min_rotation_rad)) {
      rebuild_needed_ = true;
    }
    entry.T_world_keyframe = pose.T_world_keyframe;
    FollowInCloud(key, entry);
    if (!entry.inserted && cache_.Contains(key)) {
      const Clock::time_point t0 = Clock::now();
      InsertIfReady(key, entry);
      if (entry.inserted) {
        std::lock_guard lock(mutex_);
        insert_ms_.Add(MillisecondsSince(t0));
      }
    }
  }
}

bool MapLayerBuilder::MatchStoredCloud(const Key& key, const KeyframeCloud& in_memory,
                                       const KeyframeCloudCache::Source& stored) {
  StatusOr<std::shared_ptr<const KeyframeCloud>> read = cache_.Read(stored);
  if (!read.ok()) return false;  // keep it: it could not be moved or rebuilt otherwise
  const KeyframeCloud& again = **read;
  if (again.points == in_memory.points && again.colours == in_memory.colours) return true;
  const auto it = entries_.find(key);
  if (it == entries_.end() || !it->second.T_layer_in_cloud) return true;
  // The store re-encoded its colours: the cloud layer takes the read-back colours now, so that
  // taking the keyframe out later (with what is read back then) is exact.
  const Eigen::Isometry3d& T = *it->second.T_layer_in_cloud;
  Status status = cloud_.Remove(in_memory, T);
  if (status.ok()) status = cloud_.Add(again, T);
  if (!status.ok()) {
    LogWarning("map '{}' layers: {}; rebuilding the cloud layer", map_name_, status.ToString());
    it->second.T_layer_in_cloud.reset();
    rebuild_needed_ = true;
  }
  std::lock_guard lock(mutex_);
  ++stats_.cloud_colour_swaps;
  return true;
}

bool MapLayerBuilder::LeaveOutUnreadable(const Key& key, const Status& status) {
  if (!Unreadable(status)) return false;
  LogWarning("map '{}' layers: keyframe seq {} left out: {}", map_name_, key.second,
             status.ToString());
  cache_.Erase(key);
  std::lock_guard lock(mutex_);
  ++stats_.keyframes_unreadable;
  return true;
}

std::optional<Eigen::Isometry3d> MapLayerBuilder::InLayerFrame(const Key& key, const Entry& entry) {
  if (!origin_) {
    origin_ = LayerOriginFor(entry.T_world_keyframe->translation());
    if (!origin_->isZero()) {
      LogInfo(
          "map '{}' layers: built around ({:.0f}, {:.0f}, {:.0f}) m, where its first keyframe "
          "is (exports give this layer_origin)",
          map_name_, origin_->x(), origin_->y(), origin_->z());
    }
  }
  const Eigen::Isometry3d T_layer_keyframe = LayerFromMap(*origin_) * *entry.T_world_keyframe;
  if (WithinLayerReach(T_layer_keyframe, options_.occupancy)) return T_layer_keyframe;
  if (!reach_warned_) {
    reach_warned_ = true;
    const Eigen::Vector3d t = entry.T_world_keyframe->translation();
    LogWarning(
        "map '{}' layers: keyframe seq {} at ({:.1f}, {:.1f}, {:.1f}) m is more than {:.0f} m "
        "from the layers' origin ({:.0f}, {:.0f}, {:.0f}); keyframes that far are left out of "
        "the 3D layers (they are stored and tracked; a finer --map-resolution reaches less far, "
        "a coarser one further)",
        map_name_, key.second, t.x(), t.y(), t.z(), LayerReachM(options_.occupancy), origin_->x(),
        origin_->y(), origin_->z());
  }
  return std::nullopt;
}

void MapLayerBuilder::InsertIfReady(const Key& key, Entry& entry) {
  if (!cache_.Contains(key) || !entry.T_world_keyframe) return;
  dirty_ = true;
  if (rebuild_needed_) return;  // the coming rebuild takes it in
  const std::optional<Eigen::Isometry3d> T_layer_keyframe = InLayerFrame(key, entry);
  if (!T_layer_keyframe) return;
  // In memory unless it was evicted before its pose came.
  StatusOr<std::shared_ptr<const KeyframeCloud>> cloud = cache_.Read(cache_.SourceOf(key));
  if (!cloud.ok()) {
    if (LeaveOutUnreadable(key, cloud.status())) return;
    RecordError(cloud.status().WithContext("keyframe seq " + std::to_string(key.second)));
    return;
  }
  const Status status = occupancy_.Insert(**cloud, *T_layer_keyframe);
  if (!status.ok()) {
    RecordError(status);
    return;
  }
  entry.inserted = true;
  entry.T_world_built = *entry.T_world_keyframe;
  const Status added = cloud_.Add(**cloud, *T_layer_keyframe);
  if (added.ok()) {
    entry.T_layer_in_cloud = *T_layer_keyframe;
  } else {
    RecordError(added);
  }
  std::lock_guard lock(mutex_);
  ++stats_.keyframes_inserted;
}

void MapLayerBuilder::FollowInCloud(const Key& key, Entry& entry) {
  if (rebuild_needed_ || !entry.T_layer_in_cloud || !cache_.Contains(key)) return;  // rebuilt
  const std::optional<Eigen::Isometry3d> T_layer_keyframe = InLayerFrame(key, entry);
  // A tenth of a leaf at the farthest point a cloud holds: finer moves change no leaf's mean
  // visibly, and bundle adjustment's refinements after every keyframe are mostly that small.
  const double tolerance_m = options_.cloud.leaf_size_m / 10;
  if (T_layer_keyframe && !MovedBeyond(*entry.T_layer_in_cloud, *T_layer_keyframe, tolerance_m,
                                       tolerance_m / options_.occupancy.max_range_m)) {
    return;
  }
  StatusOr<std::shared_ptr<const KeyframeCloud>> cloud = cache_.Read(cache_.SourceOf(key));
  Status status = cloud.status();
  if (status.ok()) status = cloud_.Remove(**cloud, *entry.T_layer_in_cloud);
  entry.T_layer_in_cloud.reset();
  if (status.ok() && T_layer_keyframe) {
    status = cloud_.Add(**cloud, *T_layer_keyframe);
    if (status.ok()) entry.T_layer_in_cloud = *T_layer_keyframe;
  }
  dirty_ = true;
  if (!status.ok()) {
    LogWarning("map '{}' layers: {}; rebuilding the cloud layer", map_name_, status.ToString());
    rebuild_needed_ = true;
  }
  std::lock_guard lock(mutex_);
  ++stats_.cloud_moves;
}

std::vector<std::pair<MapLayerBuilder::Key, Eigen::Isometry3d>> MapLayerBuilder::Placed() {
  std::vector<std::pair<Key, Eigen::Isometry3d>> out;
  out.reserve(entries_.size());
  uint64_t beyond = 0;
  for (const auto& [key, entry] : entries_) {
    if (!entry.T_world_keyframe || !cache_.Contains(key)) continue;
    const std::optional<Eigen::Isometry3d> T_layer_keyframe = InLayerFrame(key, entry);
    if (T_layer_keyframe) {
      out.emplace_back(key, *T_layer_keyframe);
    } else {
      ++beyond;
    }
  }
  std::lock_guard lock(mutex_);
  stats_.keyframes_beyond_reach = beyond;
  return out;
}

void MapLayerBuilder::Rebuild() {
  const Clock::time_point t0 = Clock::now();
  rebuild_needed_ = false;
  const std::vector<std::pair<Key, Eigen::Isometry3d>> placed = Placed();
  std::vector<KeyframeCloudCache::Source> sources;
  sources.reserve(placed.size());
  for (const auto& [key, T] : placed) sources.push_back(cache_.SourceOf(key));
  StatusOr<IncrementalCloud> cloud = IncrementalCloud::Create(options_.cloud);
  if (!cloud.ok()) {
    RecordError(cloud.status().WithContext("rebuild"));
    return;
  }
  // Evicted clouds are read back on the build's ray-casting thread, a few keyframes ahead of
  // the tree, and fed to the new coloured cloud as they go in: never all in memory at once. A
  // keyframe the store can no longer give (removed, damaged) is left out, not the whole rebuild.
  // Why keyframe i could not be read back (OK when it could); written before it is handed over.
  std::vector<Status> unreadable(placed.size());
  std::vector<char> in_cloud(placed.size(), 0);
  const auto source = [&](size_t i)
      -> StatusOr<std::pair<std::shared_ptr<const KeyframeCloud>, Eigen::Isometry3d>> {
    StatusOr<std::shared_ptr<const KeyframeCloud>> read = cache_.Read(sources[i]);
    if (!read.ok() && Unreadable(read.status())) {
      unreadable[i] = read.status();
      return std::make_pair(std::make_shared<const KeyframeCloud>(), placed[i].second);
    }
    SEMMAP_RETURN_IF_ERROR(read.status());
    return std::make_pair(std::move(read).value(), placed[i].second);
  };
  Status added = OkStatus();
  const auto inserted = [&](size_t i, const std::shared_ptr<const KeyframeCloud>& kf) {
    if (!unreadable[i].ok()) return;
    const Status status = cloud->Add(*kf, placed[i].second);
    if (status.ok()) {
      in_cloud[i] = 1;
    } else if (added.ok()) {
      added = status;
    }
    cache_.KeepIfRoom(placed[i].first, kf);
  };
  StatusOr<OccupancyMap> rebuilt =
      OccupancyMap::Build(placed.size(), source, options_.occupancy, {}, inserted);
  if (!rebuilt.ok()) {
    RecordError(rebuilt.status().WithContext("rebuild"));
    return;
  }
  if (!added.ok()) RecordError(added.WithContext("rebuild"));
  occupancy_ = std::move(rebuilt).value();  // the swap: the old layers served until now
  cloud_ = std::move(cloud).value();
  ReleaseFreedMemory();  // the old tree's nodes, the old cloud's leaves
  for (auto& [key, entry] : entries_) {
    entry.inserted = false;
    entry.T_layer_in_cloud.reset();
  }
  size_t inserted_count = 0;
  for (size_t i = 0; i < placed.size(); ++i) {
    if (LeaveOutUnreadable(placed[i].first, unreadable[i])) continue;
    Entry& entry = entries_.at(placed[i].first);
    entry.inserted = true;
    entry.T_world_built = *entry.T_world_keyframe;
    ++inserted_count;
    if (in_cloud[i] != 0) entry.T_layer_in_cloud = placed[i].second;
  }
  dirty_ = true;
  std::lock_guard lock(mutex_);
  stats_.keyframes_inserted = inserted_count;
  ++stats_.rebuilds;
  rebuild_ms_.Add(MillisecondsSince(t0));
}

void MapLayerBuilder::Persist() {
  const Clock::time_point t0 = Clock::now();
  // Beyond the budget, the oldest keyframes the store holds give their clouds back (first: an
  // eviction may change the cloud layer's colours, which this persist then writes).
  const Status evicted = cache_.EvictOverBudget(
      [this](const Key& key, const std::shared_ptr<const KeyframeCloud>& in_memory,
             const KeyframeCloudCache::Source& stored) {
        return MatchStoredCloud(key, *in_memory, stored);
      });
  if (!evicted.ok() && !evict_warned_) {
    evict_warned_ = true;
    LogWarning("map '{}' layers: keyframe clouds stay in memory: {}", map_name_,
               evicted.ToString());
  }
  dirty_ = false;
  last_persist_ = t0;
  StatusOr<std::string> ot = occupancy_.SerializeOt();
  if (!ot.ok()) {
    RecordError(ot.status());
    return;
  }
  Placed();  // counts the keyframes beyond reach
  const PointCloudMap cloud = cloud_.Snapshot();
  if (cloud_.points_out_of_range() > 0 && !cloud_range_warned_) {
    cloud_range_warned_ = true;
    LogWarning(
        "map '{}' layers: {} point(s) more than {:.0f} m from the layers' origin are left out of "
        "the coloured cloud (its {} m leaves are indexed that far; a coarser --cloud-voxel "
        "reaches further)",
        map_name_, cloud_.points_out_of_range(), IncrementalCloud::ReachM(options_.cloud),
        options_.cloud.leaf_size_m);
  }
  StatusOr<std::string> pcd = cloud.ToPcd(/*binary=*/true);
  if (!pcd.ok()) {
    RecordError(pcd.status());
    return;
  }
  const double known_volume = occupancy_.KnownVolume();
  {
    std::lock_guard lock(mutex_);
    stats_.octree_bytes = occupancy_.MemoryBytes();
    stats_.keyframe_cloud_bytes = cache_.resident_bytes();
    stats_.keyframes_evicted = cache_.evicted();
    stats_.keyframe_cloud_reads = cache_.reads();
    stats_.cloud_points_saturated = cloud_.points_saturated();
    stats_.cloud_layer_bytes = cloud_.MemoryBytes();
    stats_.cloud_points_out_of_range = cloud_.points_out_of_range();
    stats_.cloud_points = cloud.size();
    stats_.occupancy_blob_bytes = ot->size();
    stats_.cloud_blob_bytes = pcd->size();
    stats_.known_volume_m3 = known_volume;
    ++stats_.persists;
  }
  WriteBatch batch;
  const int64_t now = NowUnixNs();
  batch.blobs.push_back({map_id_, kOccupancyBlobKind, std::move(ot).value(), now});
  batch.blobs.push_back({map_id_, kCloudBlobKind, std::move(pcd).value(), now});
  if (origin_)
    batch.blobs.push_back({map_id_, kLayerOriginBlobKind, EncodeLayerOrigin(*origin_), now});
  writes_.Submit(std::move(batch));
  ReleaseFreedMemory();  // the snapshot's temporaries, evicted clouds
  std::lock_guard lock(mutex_);
  persist_ms_.Add(MillisecondsSince(t0));
}

}  // namespace semmap
