#include "server/serialization/object_conversions.h"

#include <algorithm>

#include "server/serialization/conversions.h"

namespace semmap {

void ToProto(const Eigen::Vector3d& v, v1::Vector3* out) {
  out->set_x(v.x());
  out->set_y(v.y());
  out->set_z(v.z());
}

Eigen::Vector3d FromProto(const v1::Vector3& v) { return {v.x(), v.y(), v.z()}; }

void ToProto(const std::array<uint8_t, 3>& rgb, v1::Colour* out) {
  out->set_r(rgb[0]);
  out->set_g(rgb[1]);
  out->set_b(rgb[2]);
}

std::array<uint8_t, 3> FromProto(const v1::Colour& colour) {
  const auto channel = [](uint32_t v) { return static_cast<uint8_t>(std::min<uint32_t>(v, 255)); };
  return {channel(colour.r()), channel(colour.g()), channel(colour.b())};
}

void ToProto(const ObjectType& type, v1::ObjectTypeInfo* out) {
  out->set_label(type.label);
  out->set_map(type.map_name);
  ToProto(type.rgb, out->mutable_colour());
  out->set_views(static_cast<uint32_t>(type.views.size()));
  size_t features = 0;
  for (const ObjectView& view : type.views) features += view.feature_count;
  out->set_features(static_cast<uint32_t>(features));
  ToProto(type.created_unix_ns, out->mutable_created());
}

ObjectType FromProto(const v1::ObjectTypeInfo& info) {
  ObjectType type;
  type.label = info.label();
  type.map_name = info.map();
  type.rgb = FromProto(info.colour());
  type.views.resize(info.views());
  type.created_unix_ns = FromProto(info.created());
  return type;
}

void ToProto(const ObjectInstance& instance, v1::ObjectInstanceInfo* out) {
  out->set_label(instance.label);
  out->set_map(instance.map_name);
  ToProto(instance.position, out->mutable_position());
  ToProto(instance.extent, out->mutable_extent());
  out->set_confidence(instance.confidence);
  out->set_observations(static_cast<uint32_t>(std::max(instance.observations, 0)));
  for (const std::string& s : instance.sessions) out->add_sessions(s);
  ToProto(instance.first_seen_ns, out->mutable_first_seen());
  ToProto(instance.last_seen_ns, out->mutable_last_seen());
  out->set_distance(instance.distance_m);
}

ObjectInstance FromProto(const v1::ObjectInstanceInfo& info) {
  ObjectInstance instance;
  instance.label = info.label();
  instance.map_name = info.map();
  instance.position = FromProto(info.position());
  instance.extent = FromProto(info.extent());
  instance.confidence = info.confidence();
  instance.observations = static_cast<int>(info.observations());
  instance.sessions.assign(info.sessions().begin(), info.sessions().end());
  instance.first_seen_ns = FromProto(info.first_seen());
  instance.last_seen_ns = FromProto(info.last_seen());
  instance.distance_m = info.distance();
  return instance;
}

}  // namespace semmap
