// The 3D layers of one map (OctoMap occupancy + coloured point cloud), built from keyframes on a
// thread of their own, off the tracking path.
//
// Two producers feed it: the ingest sessions hand over each keyframe's images (colour + depth),
// and the SLAM back end says where each keyframe is (when it joins the graph, and again after
// every optimisation). A keyframe is inserted once both have arrived. Each keyframe's cloud is
// kept in its own camera frame, so a correction only needs new poses: the occupancy tree is then
// rebuilt from all clouds in the background (several corrections queued together cost one
// rebuild) and swapped in when complete. The coloured cloud is kept current incrementally
// (IncrementalCloud): each keyframe a correction moves by more than a tenth of a cloud leaf is
// taken out at its old pose and put in at its new one, so a persist no longer filters every
// keyframe's points again. The clouds are kept within a memory budget per map
// (KeyframeCloudCache): beyond it the oldest are dropped once stored and read back from the
// stored keyframe images when a rebuild or a move needs them, so a map streamed into for hours
// does not hold every keyframe's cloud in memory.
//
// Readers never see the live tree: the products are persisted as map blobs through the storage
// writer ("octomap.ot", full-probability; "cloud.pcd", voxel-filtered binary PCD), at most every
// persist_interval_s while keyframes arrive and on every Flush(), each time from a complete
// tree and a cloud built from the current poses. Exports read those blobs (sha256-checked).
//
// A builder started for a map that already has keyframes (after a restart) first rebuilds its
// layers from the stored keyframe images and corrected poses, on its own thread, reading them
// one at a time.
//
// The layers are built in the map's layer frame (layer_frame.h: the map frame shifted by a
// per-map origin, persisted as the "layers.origin" blob); keyframes beyond the occupancy tree's
// reach from that origin are left out of the layers, counted and logged once, never an error.
#pragma once

#include <chrono>
#include <cstdint>
#include <functional>
#include <future>
#include <map>
#include <memory>
#include <mutex>
#include <opencv2/core/mat.hpp>
#include <optional>
#include <utility>
#include <variant>
#include <vector>

#include "common/camera.h"
#include "common/latency_stats.h"
#include "common/map_types.h"
#include "common/pipeline_stage.h"
#include "common/status.h"
#include "core/mapping/incremental_cloud.h"
#include "core/mapping/keyframe_cloud_cache.h"
#include "core/mapping/occupancy_map.h"
#include "core/mapping/point_cloud_map.h"
#include "core/sensor/image_decoding.h"
#include "storage/map_store_opener.h"
#include "storage/pending_writes.h"
#include "storage/storage_writer.h"

namespace semmap {

// Blob kinds of the persisted layers.
inline constexpr char kOccupancyBlobKind[] = "octomap.ot";
inline constexpr char kCloudBlobKind[] = "cloud.pcd";

struct MapLayerOptions {
  bool enabled = true;  // false: no layers are built (sessions still map and close loops)
  OccupancyMapOptions occupancy;
  PointCloudMapOptions cloud;
  size_t queue_capacity = 64;  // keyframe images and pose updates waiting for the thread
  // Blob writes while keyframes keep arriving are at most this often (a Flush always writes).
  double persist_interval_s = 2.0;
  // A correction rebuilds the occupancy tree only when it leaves some inserted keyframe more
  // than this far from the pose the tree holds it at (moves add up until they do). The
  // defaults keep every point within about half a 5 cm voxel of where the corrected pose puts
  // it (0.005 rad at the 4 m range is 2 cm), so bundle adjustment's millimetre refinements after
  // every keyframe cost no whole-map rebuilds; loop closures' corrections still do. The
  // coloured cloud is always built from the current poses.
  double rebuild_min_translation_m = 0.02;
  double rebuild_min_rotation_rad = 0.005;
  // Keyframe clouds kept in memory for rebuilds and moves; beyond this the oldest stored ones are
  // read back from the store when needed (a rebuild after a loop closure then decodes them:
  // ~3 ms per keyframe). 64 MiB holds ~500 keyframes of 640x480 depth at the 2 cm keyframe voxel.
  size_t keyframe_cloud_budget_bytes = size_t{64} << 20;

  Status Validate() const;
};

struct MapLayerStats {
  uint64_t keyframes_inserted = 0;
  uint64_t keyframes_beyond_reach = 0;  // placed too far from the layer origin: left out
  uint64_t restored_keyframes = 0;
  uint64_t rebuilds = 0;
  uint64_t persists = 0;
  size_t queue_high_water = 0;
  size_t octree_bytes = 0;                 // OctoMap's estimate for the live tree
  size_t keyframe_cloud_bytes = 0;         // clouds kept in memory for rebuilds and moves
  size_t keyframes_evicted = 0;            // whose clouds are read back from the store
  uint64_t keyframe_cloud_reads = 0;       // clouds read back from the store so far
  uint64_t keyframes_unreadable = 0;       // left out: the store could not give them back
  uint64_t cloud_colour_swaps = 0;         // evicted keyframes whose stored colours differ (JPEG)
  size_t cloud_layer_bytes = 0;            // the incremental cloud's table of leaf sums
  uint64_t cloud_moves = 0;                // keyframes moved in the cloud layer by corrections
  uint64_t cloud_points_out_of_range = 0;  // too far out for a cloud leaf's key: left out
  uint64_t cloud_points_saturated = 0;     // beyond a leaf's 2^24 points: left out
  size_t cloud_points = 0;                 // in the last persisted cloud
  size_t occupancy_blob_bytes = 0, cloud_blob_bytes = 0;
  double known_volume_m3 = 0;  // free or occupied leaves of the tree
  LatencySummary insert_ms;    // cloud + ray-casting per keyframe
  LatencySummary rebuild_ms;   // full occupancy rebuild after a correction
  LatencySummary persist_ms;   // serialise + cloud build + submit
};

namespace map_layer_internal {

struct KeyframeImages {
  int64_t session_id = 0, seq = 0;
  DecodedDepth depth;
  cv::Mat colour;
  CameraCalibration camera;
};
struct PoseUpdate {
  std::vector<KeyframePose> poses;
  bool correction = false;
};
using Event = std::variant<KeyframeImages, PoseUpdate>;

}  // namespace map_layer_internal

// A pipeline stage (common/pipeline_stage.h): Flush, Stop and metrics() come from there.
class MapLayerBuilder final : public PipelineStage<map_layer_internal::Event> {
 public:
  // `writer` must outlive the builder. With `restore`, the map's stored keyframes are loaded
  // first, on the builder's thread (ahead of every event). INVALID_ARGUMENT for bad options
  // or a null writer; RESOURCE_EXHAUSTED when its thread cannot start. `stage`: as for
  // ObjectMapper::Start.
  static StatusOr<std::unique_ptr<MapLayerBuilder>> Start(int64_t map_id, std::string map_name,
                                                          MapLayerOptions options,
                                                          StorageWriter* writer,
                                                          StoreRestore restore,
                                                          StageConfig stage = {});
  ~MapLayerBuilder() override;  // Stop(): processes what is queued, persists, joins

  // A keyframe's images (colour BGR8 or mono8, 16-bit depth; the Mats are shared, not copied).
  // Blocks only while the queue is full; UNAVAILABLE after Stop().
  Status AddKeyframeImages(int64_t session_id, int64_t seq, DecodedDepth depth, cv::Mat colour,
                           const CameraCalibration& camera);
  // Poses from the back end: a new keyframe's (correction false) or the graph's after an
  // optimisation (correction true; unchanged keyframes may be left out).
  Status SetKeyframePoses(std::vector<KeyframePose> poses, bool correction);
  // Flush(): waits until everything handed over so far is in the layers, a pending rebuild is
  // done and the blobs are committed; returns the first error since the last Flush (bad
  // images, storage).

  MapLayerStats stats() const;
  int64_t map_id() const { return map_id_; }

 private:
  using KeyframeImages = map_layer_internal::KeyframeImages;
  using PoseUpdate = map_layer_internal::PoseUpdate;
  using Key = std::pair<int64_t, int64_t>;  // (session_id, seq)
  struct Entry {  // its cloud is in cache_ once its images arrived (or it was restored)
    std::optional<Eigen::Isometry3d> T_world_keyframe;
    bool inserted = false;
    Eigen::Isometry3d T_world_built = Eigen::Isometry3d::Identity();  // the tree's, if inserted
    // Where `cloud` is in cloud_ (layer frame); nullopt when it is not in it.
    std::optional<Eigen::Isometry3d> T_layer_in_cloud;
  };

  MapLayerBuilder(int64_t map_id, std::string map_name, MapLayerOptions options,
                  StorageWriter* writer, OccupancyMap occupancy, IncrementalCloud cloud,
                  StoreRestore restore, StageConfig stage);
  // The stage's hooks (its thread).
  void OnStart() override;
  void Handle(map_layer_internal::Event& event) override;
  std::optional<Clock::time_point> OnIdle() override;
  Status OnFlush() override;
  void OnStop() override;

  void Restore();
  void Handle(KeyframeImages& images);
  void Handle(const PoseUpdate& update);
  void InsertIfReady(const Key& key, Entry& entry);
  // Moves an entry's points in cloud_ to its current pose (out when it is beyond reach) when it
  // moved more than a tenth of a leaf; a failure asks for a rebuild, which redoes cloud_.
  void FollowInCloud(const Key& key, Entry& entry);
  // Before an evicted cloud is dropped: reads it back from the store; false (keep it) when that
  // fails. When the read-back colours differ (a re-encoded JPEG), swaps them into cloud_.
  bool MatchStoredCloud(const Key& key, const KeyframeCloud& in_memory,
                        const KeyframeCloudCache::Source& stored);
  // For a cloud the store cannot give back (NOT_FOUND, DATA_LOSS): forgets it, warns and counts;
  // false for other errors.
  bool LeaveOutUnreadable(const Key& key, const Status& status);
  // T_layer_keyframe of a placed entry; nullopt (logged once) when it is beyond the layers' reach.
  std::optional<Eigen::Isometry3d> InLayerFrame(const Key& key, const Entry& entry);
  void Rebuild();
  void Persist();
  // Every keyframe with a cloud and a pose, in the layer frame (those beyond reach left out and
  // counted).
  std::vector<std::pair<Key, Eigen::Isometry3d>> Placed();
  // Runs `read` on the builder's own store reader (opened when first needed) or, without one,
  // through the writer. One call at a time (the builder's thread, or a rebuild's).
  Status ReadStore(const std::function<Status(MapStore&)>& read);

  const int64_t map_id_;
  const std::string map_name_;
  const MapLayerOptions options_;
  StorageWriter* const writer_;
  const StoreRestore restore_;

  // Builder-thread state.
  std::map<Key, Entry> entries_;
  // Set by the restore or by the first placed keyframe.
  std::optional<Eigen::Vector3d> origin_;
  bool reach_warned_ = false;
  bool cloud_range_warned_ = false;
  std::unique_ptr<MapStore> reader_;
  bool evict_warned_ = false;
  KeyframeCloudCache cache_;  // the entries' clouds
  OccupancyMap occupancy_;
  IncrementalCloud cloud_;  // the coloured cloud at the entries' T_layer_in_cloud

  bool rebuild_needed_ = false;
  bool dirty_ = false;  // layers changed since the last persist
  std::chrono::steady_clock::time_point last_persist_;

  PendingWrites writes_;      // blob writes, and the errors Flush reports
  mutable std::mutex mutex_;  // stats_, latency recorders
  MapLayerStats stats_;
  LatencyStats insert_ms_{"map_insert"};
  LatencyStats rebuild_ms_{"map_rebuild"};
  LatencyStats persist_ms_{"map_persist"};
};

}  // namespace semmap
