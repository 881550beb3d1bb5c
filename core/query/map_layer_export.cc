#include "core/query/map_layer_export.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <map>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "core/mapping/cloud_pcd_reader.h"
#include "core/mapping/layer_frame.h"
#include "core/mapping/map_render.h"
#include "core/mapping/stored_keyframe_clouds.h"

namespace semmap {
namespace {

using PlacedClouds = std::vector<std::pair<const KeyframeCloud*, Eigen::Isometry3d>>;

constexpr std::array<uint8_t, 3> kDefaultObjectColour = {255, 128, 0};

// The stored keyframes in the layer frame; those beyond the tree's reach are left out, as the
// layer builder leaves them out.
PlacedClouds Placed(const std::vector<StoredKeyframeCloud>& keyframes,
                    const Eigen::Vector3d& origin, const OccupancyMapOptions& options) {
  PlacedClouds out;
  out.reserve(keyframes.size());
  const Eigen::Isometry3d T_layer_world = LayerFromMap(origin);
  for (const StoredKeyframeCloud& kf : keyframes) {
    const Eigen::Isometry3d T_layer_keyframe = T_layer_world * kf.T_world_keyframe;
    if (WithinLayerReach(T_layer_keyframe, options))
      out.emplace_back(kf.cloud.get(), T_layer_keyframe);
  }
  return out;
}

Status NoLayersError(const std::string& map) {
  return NotFoundError("map '" + map +
                       "' has no 3D layers yet (no keyframe with depth has been mapped)");
}

// A rebuild from the stored keyframes is needed for a session filter or another resolution.
bool Rebuilds(const ExportRequest& request) {
  return !request.session.empty() || request.voxel_m > 0;
}

StatusOr<std::vector<StoredKeyframeCloud>> LoadClouds(MapStore& store, const ExportRequest& request,
                                                      const OccupancyMapOptions& options,
                                                      const CancelCheck& cancel) {
  SEMMAP_ASSIGN_OR_RETURN(std::vector<StoredKeyframeCloud> keyframes,
                          LoadKeyframeClouds(store, request.map, request.session, options, cancel));
  if (keyframes.empty()) return NoLayersError(request.map);
  return keyframes;
}

StatusOr<OccupancyMap> Occupancy(MapStore& store, const MapInfo& map, const ExportRequest& request,
                                 const MapLayerOptions& layers, const Eigen::Vector3d& origin,
                                 const CancelCheck& cancel) {
  if (Rebuilds(request)) {
    OccupancyMapOptions options = layers.occupancy;
    if (request.voxel_m > 0) options.resolution_m = request.voxel_m;
    SEMMAP_RETURN_IF_ERROR(options.Validate().WithContext("--voxel"));
    SEMMAP_ASSIGN_OR_RETURN(std::vector<StoredKeyframeCloud> keyframes,
                            LoadClouds(store, request, options, cancel));
    return OccupancyMap::Build(Placed(keyframes, origin, options), options, cancel);
  }
  StatusOr<MapBlob> blob = store.GetBlob(map.id, kOccupancyBlobKind);
  if (!blob.ok()) {
    if (blob.status().code() == StatusCode::kNotFound) return NoLayersError(map.name);
    return blob.status();
  }
  StatusOr<OccupancyMap> occupancy = OccupancyMap::DeserializeOt(blob->data, layers.occupancy);
  if (!occupancy.ok()) {
    // The bytes passed their checksum, so they were stored this way: the layer is unusable.
    return DataLossError("stored occupancy map of '" + map.name +
                         "': " + occupancy.status().message());
  }
  return occupancy;
}

StatusOr<PointCloudMap> Cloud(MapStore& store, const MapInfo& map, const ExportRequest& request,
                              const MapLayerOptions& layers, const Eigen::Vector3d& origin,
                              const CancelCheck& cancel) {
  PointCloudMapOptions options = layers.cloud;
  if (request.voxel_m > 0) options.leaf_size_m = request.voxel_m;
  SEMMAP_RETURN_IF_ERROR(options.Validate().WithContext("--voxel"));
  if (!request.session.empty()) {
    SEMMAP_ASSIGN_OR_RETURN(std::vector<StoredKeyframeCloud> keyframes,
                            LoadClouds(store, request, layers.occupancy, cancel));
    return PointCloudMap::Build(Placed(keyframes, origin, layers.occupancy), options, cancel);
  }
  StatusOr<MapBlob> blob = store.GetBlob(map.id, kCloudBlobKind);
  if (!blob.ok()) {
    if (blob.status().code() == StatusCode::kNotFound) return NoLayersError(map.name);
    return blob.status();
  }
  StatusOr<std::vector<CloudPoint>> points = ReadCloudPcd(blob->data);
  if (!points.ok()) {
    return DataLossError("stored cloud of '" + map.name + "': " + points.status().message());
  }
  if (request.voxel_m <= 0) return PointCloudMap::FromPoints(std::move(points).value(), options);
  // Another leaf: filter the stored cloud again (one "keyframe" at the origin).
  KeyframeCloud merged;
  merged.points.reserve(points->size());
  merged.colours.reserve(points->size());
  for (const CloudPoint& p : *points) {
    merged.points.emplace_back(p.x, p.y, p.z);
    merged.colours.push_back({p.b, p.g, p.r});
  }
  return PointCloudMap::Build({{&merged, Eigen::Isometry3d::Identity()}}, options, cancel);
}

struct MapObjects {
  std::vector<ObjectInstance> instances;
  std::map<int64_t, std::array<uint8_t, 3>> colours;  // by type id
};

StatusOr<MapObjects> LoadObjects(MapStore& store, const MapInfo& map) {
  MapObjects out;
  SEMMAP_ASSIGN_OR_RETURN(out.instances, store.FindObjectInstances(map.id, ""));
  SEMMAP_ASSIGN_OR_RETURN(std::vector<ObjectType> types,
                          store.ListObjectTypes(map.id, /*with_views=*/false));
  for (const ObjectType& t : types) out.colours[t.id] = t.rgb;
  return out;
}

// An object's box drawn into the cloud: points every 5 mm along its 12 edges, in its type's
// colour (boxes at least 5 cm on a side, so small objects stay visible).
void AppendBox(const ObjectInstance& o, const std::array<uint8_t, 3>& rgb,
               const Eigen::Vector3d& origin, std::vector<CloudPoint>& points) {
  const Eigen::Vector3d half = 0.5 * o.extent.cwiseMax(Eigen::Vector3d::Constant(0.05));
  const Eigen::Vector3d centre = o.position - origin;  // layer frame
  const Eigen::Vector3d lo = centre - half, hi = centre + half;
  for (int axis = 0; axis < 3; ++axis) {
    const int a = (axis + 1) % 3, b = (axis + 2) % 3;
    const int steps = std::max(1, static_cast<int>((hi[axis] - lo[axis]) / 0.005));
    for (int corner = 0; corner < 4; ++corner) {
      Eigen::Vector3d p;
      p[a] = (corner & 1) ? hi[a] : lo[a];
      p[b] = (corner & 2) ? hi[b] : lo[b];
      for (int i = 0; i <= steps; ++i) {
        p[axis] = lo[axis] + (hi[axis] - lo[axis]) * i / steps;
        points.push_back({static_cast<float>(p.x()), static_cast<float>(p.y()),
                          static_cast<float>(p.z()), rgb[0], rgb[1], rgb[2]});
      }
    }
  }
}

// The renderer draws within 1e6 m of the layer origin: poses farther (only possible for maps
// that span continents) are left out of the picture and counted in its title.
constexpr double kRenderReachM = 1e6;

bool Drawable(const Eigen::Vector3d& p_layer) {
  return p_layer.allFinite() && p_layer.cwiseAbs().maxCoeff() <= kRenderReachM;
}

StatusOr<std::string> RenderPng(MapStore& store, const MapInfo& map, const ExportRequest& request,
                                const MapLayerOptions& layers, const Eigen::Vector3d& origin,
                                const CancelCheck& cancel) {
  MapRenderOptions options;
  if (request.width_px > 0) options.long_side_px = request.width_px;
  if (request.view == "oblique") {
    options.view = RenderView::kOblique;
  } else if (!request.view.empty() && request.view != "top") {
    return InvalidArgumentError("unknown view '" + request.view + "' (top, oblique)");
  }
  SEMMAP_RETURN_IF_ERROR(options.Validate());

  MapRenderInput input;
  input.title = "map '" + map.name + "'" +
                (request.session.empty() ? "" : " session '" + request.session + "'");
  StatusOr<PointCloudMap> cloud = Cloud(store, map, request, layers, origin, cancel);
  // A map without layers (no depth) still shows its trajectories.
  if (!cloud.ok() && cloud.status().code() != StatusCode::kNotFound) return cloud.status();
  if (cloud.ok()) input.cloud = cloud->points();
  SEMMAP_ASSIGN_OR_RETURN(std::vector<SessionInfo> sessions, store.ListSessions(map.name));
  std::map<int64_t, Eigen::Vector3d> keyframe_positions;  // by keyframe id, layer frame
  const Eigen::Isometry3d T_layer_world = LayerFromMap(origin);
  size_t undrawable = 0;
  bool matched = request.session.empty();
  for (const SessionInfo& s : sessions) {
    const bool shown = request.session.empty() || s.name == request.session;
    matched = matched || shown;
    SEMMAP_ASSIGN_OR_RETURN(std::vector<KeyframeRecord> keyframes,
                            store.ListKeyframes(s.id, /*with_images=*/false));
    for (const KeyframeRecord& kf : keyframes) {
      const Eigen::Isometry3d T_layer_keyframe = T_layer_world * kf.T_world_camera;
      if (!Drawable(T_layer_keyframe.translation())) {
        undrawable += shown ? 1 : 0;
        continue;
      }
      keyframe_positions[kf.id] = T_layer_keyframe.translation();
      if (shown) input.keyframes.push_back(T_layer_keyframe);
    }
    if (!shown) continue;
    SEMMAP_ASSIGN_OR_RETURN(std::vector<TrajectoryPose> poses,
                            store.GetTrajectory(s.id, /*keyframes_only=*/false));
    std::vector<Eigen::Isometry3d>& trajectory = input.trajectories.emplace_back();
    for (const TrajectoryPose& p : poses) {
      if (p.lost) continue;
      const Eigen::Isometry3d T_layer_camera = T_layer_world * p.T_world_camera;
      if (Drawable(T_layer_camera.translation())) {
        trajectory.push_back(T_layer_camera);
      } else {
        ++undrawable;
      }
    }
  }
  if (!matched) {
    return NotFoundError("map '" + map.name + "' has no session '" + request.session + "'");
  }
  SEMMAP_ASSIGN_OR_RETURN(MapObjects objects, LoadObjects(store, map));
  for (const ObjectInstance& o : objects.instances) {
    if (!Drawable(o.position - origin)) continue;
    RenderObject object;
    object.label = o.label;
    object.centre = o.position - origin;
    object.extent = o.extent;
    const auto colour = objects.colours.find(o.type_id);
    if (colour != objects.colours.end()) object.rgb = colour->second;
    input.objects.push_back(std::move(object));
  }
  SEMMAP_ASSIGN_OR_RETURN(std::vector<LinkRecord> links, store.ListLinks(map.id));
  for (const LinkRecord& link : links) {
    if (link.kind != LinkKind::kLoop) continue;
    const auto from = keyframe_positions.find(link.from_keyframe_id);
    const auto to = keyframe_positions.find(link.to_keyframe_id);
    if (from != keyframe_positions.end() && to != keyframe_positions.end()) {
      input.loop_edges.emplace_back(from->second, to->second);
    }
  }
  if (!origin.isZero()) {
    char shift[96];
    std::snprintf(shift, sizeof(shift), " (map frame shifted by -(%.0f, %.0f, %.0f) m)", origin.x(),
                  origin.y(), origin.z());
    input.title += shift;
  }
  if (undrawable > 0) {
    input.title += "; " + std::to_string(undrawable) + " poses beyond 1000 km not drawn";
  }
  SEMMAP_RETURN_IF_ERROR(CheckNotCancelled(cancel));
  return RenderMapPng(input, options);
}

// Names the layer origin inside the file too, for 3D formats that have comments.
std::string WithOriginComment(std::string bytes, const std::string& format,
                              const Eigen::Vector3d& origin) {
  if (origin.isZero()) return bytes;
  char text[128];
  std::snprintf(text, sizeof(text), "semmap layer_origin %.17g %.17g %.17g (map = layer + origin)",
                origin.x(), origin.y(), origin.z());
  if (format == "pcd") return "# " + std::string(text) + "\n" + bytes;
  // PLY: comments go after the "format" line.
  const size_t format_line = bytes.find('\n', bytes.find("\nformat "));
  if (format == "ply" && format_line != std::string::npos) {
    bytes.insert(format_line + 1, "comment " + std::string(text) + "\n");
  }
  return bytes;
}

}  // namespace

bool IsLayerExportFormat(const std::string& format) {
  return format == "ot" || format == "bt" || format == "ply" || format == "pcd" || format == "png";
}

StatusOr<ExportResult> BuildLayerExport(MapStore& store, const ExportRequest& request,
                                        const MapLayerOptions& layers, const CancelCheck& cancel) {
  if (!std::isfinite(request.voxel_m) || request.voxel_m < 0) {
    return InvalidArgumentError("voxel size must be a finite number >= 0");
  }
  SEMMAP_ASSIGN_OR_RETURN(MapInfo map, store.GetMap(request.map));
  StatusOr<std::optional<Eigen::Vector3d>> stored_origin = ReadLayerOrigin(store, map.id, map.name);
  if (!stored_origin.ok()) {
    return DataLossError("map '" + map.name + "': " + stored_origin.status().message());
  }
  const Eigen::Vector3d origin = stored_origin->value_or(Eigen::Vector3d::Zero());
  ExportResult result;
  result.format = request.format;
  result.layer_origin = origin;
  if (request.format == "ot" || request.format == "bt") {
    result.media_type = "application/octet-stream";
    SEMMAP_ASSIGN_OR_RETURN(OccupancyMap occupancy,
                            Occupancy(store, map, request, layers, origin, cancel));
    SEMMAP_ASSIGN_OR_RETURN(
        result.bytes, request.format == "ot" ? occupancy.SerializeOt() : occupancy.SerializeBt());
  } else if (request.format == "ply" || request.format == "pcd") {
    result.media_type = request.format == "ply" ? "application/x-ply" : "application/x-pcd";
    SEMMAP_ASSIGN_OR_RETURN(PointCloudMap cloud,
                            Cloud(store, map, request, layers, origin, cancel));
    if (request.format == "ply") {
      // The map's objects appear as boxes in their colours (PCD stays the plain cloud).
      SEMMAP_ASSIGN_OR_RETURN(MapObjects objects, LoadObjects(store, map));
      if (!objects.instances.empty()) {
        std::vector<CloudPoint> points = cloud.points();
        for (const ObjectInstance& o : objects.instances) {
          const auto colour = objects.colours.find(o.type_id);
          AppendBox(o, colour != objects.colours.end() ? colour->second : kDefaultObjectColour,
                    origin, points);
        }
        cloud = PointCloudMap::FromPoints(std::move(points), cloud.options());
      }
      SEMMAP_ASSIGN_OR_RETURN(result.bytes, cloud.ToPly(!request.ascii));
    } else {
      SEMMAP_ASSIGN_OR_RETURN(result.bytes, cloud.ToPcd(!request.ascii));
    }
    result.bytes = WithOriginComment(std::move(result.bytes), request.format, origin);
  } else if (request.format == "png") {
    result.media_type = "image/png";
    SEMMAP_ASSIGN_OR_RETURN(result.bytes, RenderPng(store, map, request, layers, origin, cancel));
  } else {
    return InvalidArgumentError("not a layer export format: '" + request.format + "'");
  }
  return result;
}

}  // namespace semmap
