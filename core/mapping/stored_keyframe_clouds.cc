#include "core/mapping/stored_keyframe_clouds.h"

#include <string>
#include <utility>

#include "core/mapping/layer_frame.h"
#include "core/sensor/image_decoding.h"

namespace semmap {

StatusOr<KeyframeCloud> KeyframeCloudFromRecord(const KeyframeRecord& record,
                                                const CameraCalibration& camera,
                                                const OccupancyMapOptions& options) {
  const std::string where =
      "keyframe " + std::to_string(record.id) + " (seq " + std::to_string(record.seq) + ")";
  if (record.depth.empty() || record.depth_scale <= 0) {
    return InvalidArgumentError(where + " has no depth");
  }
  ImageMessage colour;
  colour.kind = ImageMessage::Kind::kCompressed;
  colour.encoding = record.colour.format;
  colour.data = record.colour.bytes;
  DepthMessage depth;
  depth.image.kind = ImageMessage::Kind::kCompressed;
  depth.image.encoding = record.depth.format;
  depth.image.data = record.depth.bytes;
  depth.depth_scale = record.depth_scale;
  const int width = camera.width, height = camera.height;
  // What the store returns was validated on the way in: a failure now means damaged bytes.
  StatusOr<cv::Mat> bgr = DecodeColour(colour, width, height);
  if (!bgr.ok()) return DataLossError(where + ": stored colour: " + bgr.status().message());
  StatusOr<DecodedDepth> decoded = DecodeDepth(depth, width, height);
  if (!decoded.ok()) return DataLossError(where + ": stored depth: " + decoded.status().message());
  return MakeKeyframeCloud(*decoded, *bgr, camera, options);
}

StatusOr<StoredKeyframeRefs> ListStoredKeyframes(MapStore& store, const std::string& map_name) {
  SEMMAP_ASSIGN_OR_RETURN(std::vector<SessionInfo> sessions, store.ListSessions(map_name));
  StoredKeyframeRefs out;
  for (const SessionInfo& session : sessions) {
    SEMMAP_ASSIGN_OR_RETURN(std::vector<KeyframeRecord> keyframes,
                            store.ListKeyframes(session.id, /*with_images=*/false));
    out.cameras[session.id] = session.camera;
    for (const KeyframeRecord& record : keyframes) {
      if (record.depth_scale <= 0) continue;  // no depth: no cloud
      out.keyframes.push_back({session.id, record.seq, record.id, record.T_world_camera});
    }
  }
  return out;
}

StatusOr<KeyframeCloud> ReadStoredKeyframeCloud(MapStore& store, int64_t keyframe_id,
                                                const CameraCalibration& camera,
                                                const OccupancyMapOptions& options) {
  SEMMAP_ASSIGN_OR_RETURN(const KeyframeRecord record, store.GetKeyframe(keyframe_id));
  return KeyframeCloudFromRecord(record, camera, options);
}

StatusOr<std::optional<Eigen::Vector3d>> ReadLayerOrigin(MapStore& store, int64_t map_id,
                                                         const std::string& map_name) {
  StatusOr<MapBlob> blob = store.GetBlob(map_id, kLayerOriginBlobKind);
  if (blob.ok()) {
    SEMMAP_ASSIGN_OR_RETURN(Eigen::Vector3d origin, DecodeLayerOrigin(blob->data));
    return std::optional<Eigen::Vector3d>(origin);
  }
  if (blob.status().code() != StatusCode::kNotFound) return blob.status();
  return FirstKeyframeLayerOrigin(store, map_name);
}

StatusOr<std::optional<Eigen::Vector3d>> FirstKeyframeLayerOrigin(MapStore& store,
                                                                  const std::string& map_name) {
  SEMMAP_ASSIGN_OR_RETURN(std::vector<SessionInfo> sessions, store.ListSessions(map_name));
  for (const SessionInfo& session : sessions) {  // in creation order
    SEMMAP_ASSIGN_OR_RETURN(std::vector<KeyframeRecord> keyframes,
                            store.ListKeyframes(session.id, /*with_images=*/false));
    if (!keyframes.empty()) {
      return std::optional<Eigen::Vector3d>(
          LayerOriginFor(keyframes.front().T_world_camera.translation()));
    }
  }
  return std::optional<Eigen::Vector3d>();
}

StatusOr<std::vector<StoredKeyframeCloud>> LoadKeyframeClouds(MapStore& store,
                                                              const std::string& map_name,
                                                              const std::string& session_name,
                                                              const OccupancyMapOptions& options,
                                                              const CancelCheck& cancel) {
  SEMMAP_ASSIGN_OR_RETURN(std::vector<SessionInfo> sessions, store.ListSessions(map_name));
  std::vector<StoredKeyframeCloud> out;
  bool matched = session_name.empty();
  for (const SessionInfo& session : sessions) {
    if (!session_name.empty() && session.name != session_name) continue;
    matched = true;
    SEMMAP_ASSIGN_OR_RETURN(std::vector<KeyframeRecord> keyframes,
                            store.ListKeyframes(session.id, /*with_images=*/true));
    for (const KeyframeRecord& record : keyframes) {
      if (record.depth.empty()) continue;
      SEMMAP_RETURN_IF_ERROR(CheckNotCancelled(cancel));
      StatusOr<KeyframeCloud> cloud = KeyframeCloudFromRecord(record, session.camera, options);
      SEMMAP_RETURN_IF_ERROR(cloud.status());
      out.push_back({session.id, record.seq, record.T_world_camera,
                     std::make_shared<const KeyframeCloud>(std::move(cloud).value())});
    }
  }
  if (!matched) {
    return NotFoundError("map '" + map_name + "' has no session '" + session_name + "'");
  }
  return out;
}

}  // namespace semmap
