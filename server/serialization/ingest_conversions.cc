#include "server/serialization/ingest_conversions.h"

#include <cstdint>
#include <string>
#include <utility>

#include "server/serialization/wire_parsing.h"

namespace semmap {
namespace {

ImageMessage TakeImage(v1::Image* image) {
  ImageMessage out;
  if (image->has_compressed()) {
    out.kind = ImageMessage::Kind::kCompressed;
    out.encoding = image->compressed().format();
    out.data = std::move(*image->mutable_compressed()->mutable_data());
  } else {
    out.kind = ImageMessage::Kind::kRaw;
    const v1::RawImage& raw = image->raw();
    out.encoding = raw.encoding();
    out.width = raw.width();
    out.height = raw.height();
    out.step = raw.step();
    out.data = std::move(*image->mutable_raw()->mutable_data());
  }
  return out;
}

IngestMessage ConvertStart(const v1::IngestStart& in) {
  IngestStartRequest start;
  start.map = in.map();
  start.session = in.session();
  start.mode = FromProto(in.mode());
  if (!in.has_camera()) return IngestInvalid{InvalidArgumentError("start has no camera")};
  StatusOr<CameraCalibration> camera = FromProto(in.camera());
  if (!camera.ok()) return IngestInvalid{camera.status().WithContext("start.camera")};
  start.camera = *camera;
  start.keyframe_min_motion = in.keyframes().min_motion();
  start.keyframe_rotation_weight = in.keyframes().rotation_weight();
  return start;
}

IngestMessage ConvertFrame(v1::Frame* in) {
  IngestFrame frame;
  frame.seq = in->seq();
  if (in->has_timestamp()) {
    StatusOr<int64_t> stamp = StampNsFromProto(in->timestamp());
    if (!stamp.ok()) {
      return IngestInvalid{stamp.status().WithContext("frame seq " + std::to_string(frame.seq))};
    }
    frame.stamp_ns = *stamp;
  }
  if (in->has_colour()) {
    if (in->colour().kind_case() == v1::Image::KIND_NOT_SET) {
      return IngestInvalid{InvalidArgumentError("frame seq " + std::to_string(frame.seq) +
                                                " has an empty colour image")};
    }
    frame.colour = TakeImage(in->mutable_colour());
    frame.payload_bytes += frame.colour->data.size();
  }
  if (in->has_depth() && in->depth().has_image()) {
    if (in->depth().image().kind_case() == v1::Image::KIND_NOT_SET) {
      return IngestInvalid{InvalidArgumentError("frame seq " + std::to_string(frame.seq) +
                                                " has an empty depth image")};
    }
    DepthMessage depth;
    depth.depth_scale = in->depth().depth_scale();
    depth.image = TakeImage(in->mutable_depth()->mutable_image());
    frame.payload_bytes += depth.image.data.size();
    frame.depth = std::move(depth);
  }
  if (in->has_pose_prior()) frame.pose_prior = FromProto(in->pose_prior());
  return frame;
}

// `wire` is a grpc::ByteBuffer or a string_view (both have a ParseWire).
template <typename Wire>
IngestMessage Parse(const Wire& wire, uint64_t index) {
  v1::IngestRequest request;
  const Status parsed =
      ParseWire(wire, &request, "message " + std::to_string(index) + " of the ingest stream");
  if (!parsed.ok()) {
    return IngestInvalid{Status(parsed.code(), parsed.message() + "; nothing from it on was read")};
  }
  return FromProto(std::move(request));
}

}  // namespace

IngestMessage ParseIngestRequest(const grpc::ByteBuffer& buffer, uint64_t index) {
  return Parse(buffer, index);
}

IngestMessage ParseIngestRequest(std::string_view bytes, uint64_t index) {
  return Parse(bytes, index);
}

IngestMessage FromProto(v1::IngestRequest&& request) {
  switch (request.msg_case()) {
    case v1::IngestRequest::kStart:
      return ConvertStart(request.start());
    case v1::IngestRequest::kFrame:
      return ConvertFrame(request.mutable_frame());
    case v1::IngestRequest::kEnd:
      return IngestEnd{};
    case v1::IngestRequest::MSG_NOT_SET:
      break;
  }
  return IngestInvalid{InvalidArgumentError("empty ingest message (no start, frame or end)")};
}

void ToProto(const SessionInfo& session, v1::IngestStarted* out) {
  out->set_map(session.map_name);
  out->set_session(session.name);
}

void ToProto(const FrameAckInfo& ack, v1::FrameAck* out) {
  out->set_seq(ack.seq);
  ToProto(ack.T_world_camera, out->mutable_t_world_camera());
  out->set_is_keyframe(ack.is_keyframe);
  out->set_lost(ack.lost);
  if (ack.durable_seq) out->set_durable_seq(*ack.durable_seq);
}

void ToProto(const IngestProgressInfo& p, v1::IngestProgress* out) {
  out->set_frames_received(p.frames_received);
  out->set_frames_processed(p.frames_processed);
  out->set_keyframes(p.keyframes);
  if (p.durable_seq) out->set_durable_seq(*p.durable_seq);
  out->set_queue_depth(p.queue_depth);
}

void ToProto(const IngestSummaryInfo& s, v1::IngestSummary* out) {
  out->set_map(s.map);
  out->set_session(s.session);
  out->set_frames(s.frames);
  out->set_keyframes(s.keyframes);
  if (s.durable_seq) out->set_durable_seq(*s.durable_seq);
  out->set_duration_s(s.duration_s);
  out->set_lost_frames(s.lost_frames);
  out->set_loop_closures(s.loop_closures);
  out->set_new_segments(s.new_segments);
  for (const LatencySummary& stage : s.stages) {
    v1::StageLatency* wire = out->add_stages();
    wire->set_name(stage.name);
    wire->set_count(stage.count);
    wire->set_p50_ms(stage.p50_ms);
    wire->set_p95_ms(stage.p95_ms);
    wire->set_max_ms(stage.max_ms);
    wire->set_mean_ms(stage.mean_ms);
  }
}

}  // namespace semmap
