#include "server/serialization/conversions.h"

#include <cmath>
#include <limits>
#include <string>

namespace semmap {

grpc::Status ToGrpcStatus(const Status& status) {
  if (status.ok()) return grpc::Status::OK;
  return grpc::Status(static_cast<grpc::StatusCode>(status.code()), status.message());
}

Status FromGrpcStatus(const grpc::Status& status) {
  if (status.ok()) return OkStatus();
  return Status(static_cast<StatusCode>(status.error_code()), status.error_message());
}

void ToProto(int64_t stamp_ns, google::protobuf::Timestamp* out) {
  int64_t seconds = stamp_ns / 1'000'000'000;
  int64_t nanos = stamp_ns % 1'000'000'000;
  if (nanos < 0) {  // Timestamp wants 0 <= nanos < 1e9
    nanos += 1'000'000'000;
    --seconds;
  }
  out->set_seconds(seconds);
  out->set_nanos(static_cast<int32_t>(nanos));
}

StatusOr<int64_t> StampNsFromProto(const google::protobuf::Timestamp& stamp) {
  if (stamp.nanos() < 0 || stamp.nanos() > 999'999'999) {
    return InvalidArgumentError("timestamp nanos " + std::to_string(stamp.nanos()) +
                                " is not in 0..999999999");
  }
  // int64 nanoseconds reach from 1677-09-21 to 2262-04-11.
  constexpr int64_t kMaxSeconds = std::numeric_limits<int64_t>::max() / 1'000'000'000 - 1;
  if (stamp.seconds() < -kMaxSeconds || stamp.seconds() > kMaxSeconds) {
    return InvalidArgumentError("timestamp " + std::to_string(stamp.seconds()) +
                                " s is outside what nanoseconds since 1970 in 64 bits can hold "
                                "(years 1677..2262)");
  }
  return stamp.seconds() * 1'000'000'000 + stamp.nanos();
}

int64_t FromProto(const google::protobuf::Timestamp& stamp) {
  // What a peer sends is not trusted to be in range: clamped, never undefined.
  StatusOr<int64_t> ns = StampNsFromProto(stamp);
  if (ns.ok()) return *ns;
  return stamp.seconds() < 0 ? std::numeric_limits<int64_t>::min()
                             : std::numeric_limits<int64_t>::max();
}

void ToProto(const Eigen::Isometry3d& T, v1::Pose* out) {
  const PoseTq tq = ToPoseTq(T);
  out->mutable_position()->set_x(tq.t.x());
  out->mutable_position()->set_y(tq.t.y());
  out->mutable_position()->set_z(tq.t.z());
  out->mutable_orientation()->set_x(tq.q.x());
  out->mutable_orientation()->set_y(tq.q.y());
  out->mutable_orientation()->set_z(tq.q.z());
  out->mutable_orientation()->set_w(tq.q.w());
}

PoseTq FromProto(const v1::Pose& pose) {
  PoseTq tq;
  tq.t = Eigen::Vector3d(pose.position().x(), pose.position().y(), pose.position().z());
  tq.q = Eigen::Quaterniond(pose.orientation().w(), pose.orientation().x(), pose.orientation().y(),
                            pose.orientation().z());
  return tq;
}

void ToProto(const CameraCalibration& c, v1::CameraCalibration* out) {
  out->set_width(c.width);
  out->set_height(c.height);
  out->set_distortion_model("plumb_bob");
  out->clear_d();
  for (double d : c.distortion) out->add_d(d);
  out->clear_k();
  for (double k : {c.fx, 0.0, c.cx, 0.0, c.fy, c.cy, 0.0, 0.0, 1.0}) out->add_k(k);
}

StatusOr<CameraCalibration> FromProto(const v1::CameraCalibration& in) {
  if (in.k_size() != 9) {
    return InvalidArgumentError("camera K must have 9 values (row-major 3x3), got " +
                                std::to_string(in.k_size()));
  }
  if (in.d_size() != 0 && in.d_size() != 5) {
    return InvalidArgumentError("camera D must have 5 values (k1 k2 p1 p2 k3) or none, got " +
                                std::to_string(in.d_size()));
  }
  if (!in.distortion_model().empty() && in.distortion_model() != "plumb_bob") {
    return InvalidArgumentError("camera distortion model '" + in.distortion_model() +
                                "' is not supported (use plumb_bob)");
  }
  const auto& K = in.k();
  if (K[1] != 0 || K[3] != 0 || K[6] != 0 || K[7] != 0 || K[8] != 1) {
    return InvalidArgumentError(
        "camera K must be a pinhole matrix [fx 0 cx; 0 fy cy; 0 0 1] (no skew)");
  }
  CameraCalibration c;
  c.width = static_cast<int>(std::min<uint32_t>(in.width(), 1u << 30));
  c.height = static_cast<int>(std::min<uint32_t>(in.height(), 1u << 30));
  c.fx = K[0];
  c.cx = K[2];
  c.fy = K[4];
  c.cy = K[5];
  for (int i = 0; i < in.d_size(); ++i) c.distortion[i] = in.d(i);
  return c;
}

std::optional<SessionMode> FromProto(v1::SessionMode mode) {
  switch (mode) {
    case v1::SESSION_MODE_RGBD:
      return SessionMode::kRgbd;
    case v1::SESSION_MODE_MONO:
      return SessionMode::kMono;
    case v1::SESSION_MODE_KNOWN_POSES:
      return SessionMode::kKnownPoses;
    default:
      return std::nullopt;
  }
}

v1::SessionMode ToProto(SessionMode mode) {
  switch (mode) {
    case SessionMode::kRgbd:
      return v1::SESSION_MODE_RGBD;
    case SessionMode::kMono:
      return v1::SESSION_MODE_MONO;
    case SessionMode::kKnownPoses:
      return v1::SESSION_MODE_KNOWN_POSES;
  }
  return v1::SESSION_MODE_UNSPECIFIED;
}

void ToProto(const MapInfo& map, v1::MapInfo* out) {
  out->set_name(map.name);
  ToProto(map.created_unix_ns, out->mutable_created());
  out->set_session_count(map.session_count);
  out->set_keyframe_count(map.keyframe_count);
}

MapInfo FromProto(const v1::MapInfo& in) {
  MapInfo map;
  map.name = in.name();
  map.created_unix_ns = FromProto(in.created());
  map.session_count = static_cast<int64_t>(in.session_count());
  map.keyframe_count = static_cast<int64_t>(in.keyframe_count());
  return map;
}

void ToProto(const SessionInfo& s, v1::SessionInfo* out) {
  out->set_map(s.map_name);
  out->set_name(s.name);
  out->set_mode(ToProto(s.mode));
  ToProto(s.camera, out->mutable_camera());
  out->set_depth_scale(s.depth_scale);
  ToProto(s.started_unix_ns, out->mutable_started());
  if (s.ended_unix_ns != 0) ToProto(s.ended_unix_ns, out->mutable_ended());
  out->set_frame_count(s.frame_count);
  out->set_keyframe_count(s.keyframe_count);
  out->set_end_reason(static_cast<v1::SessionEndReason>(s.end_reason));  // same values
  out->set_end_message(s.end_message);
}

SessionInfo FromProto(const v1::SessionInfo& in) {
  SessionInfo s;
  s.map_name = in.map();
  s.name = in.name();
  s.mode = FromProto(in.mode()).value_or(SessionMode::kKnownPoses);
  StatusOr<CameraCalibration> camera = FromProto(in.camera());
  if (camera.ok()) s.camera = *camera;
  s.depth_scale = in.depth_scale();
  s.started_unix_ns = FromProto(in.started());
  s.ended_unix_ns = in.has_ended() ? FromProto(in.ended()) : 0;
  s.frame_count = static_cast<int64_t>(in.frame_count());
  s.keyframe_count = static_cast<int64_t>(in.keyframe_count());
  // A newer server may know more reasons; they read as unspecified.
  const int reason = in.end_reason();
  if (reason >= 0 && reason <= static_cast<int>(SessionEndReason::kCrashed)) {
    s.end_reason = static_cast<SessionEndReason>(reason);
  }
  s.end_message = in.end_message();
  return s;
}

void ToProto(const TrajectoryPose& p, v1::TrajectoryPose* out) {
  out->set_seq(static_cast<uint64_t>(p.seq));
  ToProto(p.stamp_ns, out->mutable_timestamp());
  ToProto(p.T_world_camera, out->mutable_t_world_camera());
  out->set_is_keyframe(p.is_keyframe);
  out->set_lost(p.lost);
}

TrajectoryPose FromProto(const v1::TrajectoryPose& in) {
  TrajectoryPose p;
  p.seq = static_cast<int64_t>(in.seq());
  p.stamp_ns = FromProto(in.timestamp());
  p.T_world_camera = ToIsometry(FromProto(in.t_world_camera()));
  p.is_keyframe = in.is_keyframe();
  p.lost = in.lost();
  return p;
}

}  // namespace semmap
