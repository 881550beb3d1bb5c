// Wire <-> domain conversions of object types and instances (service and client library).
#pragma once

#include <Eigen/Core>
#include <array>
#include <cstdint>

#include "common/object_types.h"
#include "semmap/v1/objects.pb.h"

namespace semmap {

void ToProto(const Eigen::Vector3d& v, v1::Vector3* out);
Eigen::Vector3d FromProto(const v1::Vector3& v);

void ToProto(const std::array<uint8_t, 3>& rgb, v1::Colour* out);
// Channels above 255 are clamped (the server validates before this where it matters).
std::array<uint8_t, 3> FromProto(const v1::Colour& colour);

// views / features: what the summary reports (counted from type.views when present).
void ToProto(const ObjectType& type, v1::ObjectTypeInfo* out);
ObjectType FromProto(const v1::ObjectTypeInfo& info);

void ToProto(const ObjectInstance& instance, v1::ObjectInstanceInfo* out);
ObjectInstance FromProto(const v1::ObjectInstanceInfo& info);

}  // namespace semmap
