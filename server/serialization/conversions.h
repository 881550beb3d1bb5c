// Wire <-> domain conversions shared by the service and the client library.
#pragma once

#include <google/protobuf/timestamp.pb.h>
#include <grpcpp/support/status.h>

#include "common/camera.h"
#include "common/map_types.h"
#include "common/pose.h"
#include "common/status.h"
#include "semmap/v1/service.pb.h"

namespace semmap {

grpc::Status ToGrpcStatus(const Status& status);
Status FromGrpcStatus(const grpc::Status& status);

void ToProto(int64_t stamp_ns, google::protobuf::Timestamp* out);
// INVALID_ARGUMENT for nanos outside 0..999999999 or a time int64 nanoseconds cannot hold.
StatusOr<int64_t> StampNsFromProto(const google::protobuf::Timestamp& stamp);
// The same, clamped to the int64 range instead of failing (for stamps a server sent).
int64_t FromProto(const google::protobuf::Timestamp& stamp);

void ToProto(const Eigen::Isometry3d& T, v1::Pose* out);
PoseTq FromProto(const v1::Pose& pose);  // not validated: call ValidatePoseTq

void ToProto(const CameraCalibration& camera, v1::CameraCalibration* out);
// INVALID_ARGUMENT when K or D have the wrong length or K is not a pinhole matrix.
StatusOr<CameraCalibration> FromProto(const v1::CameraCalibration& camera);

std::optional<SessionMode> FromProto(v1::SessionMode mode);
v1::SessionMode ToProto(SessionMode mode);

void ToProto(const MapInfo& map, v1::MapInfo* out);
MapInfo FromProto(const v1::MapInfo& map);
void ToProto(const SessionInfo& session, v1::SessionInfo* out);
SessionInfo FromProto(const v1::SessionInfo& session);
void ToProto(const TrajectoryPose& pose, v1::TrajectoryPose* out);
TrajectoryPose FromProto(const v1::TrajectoryPose& pose);

}  // namespace semmap
