// Helpers to build Ingest messages for service tests.
#pragma once

#include <Eigen/Geometry>
#include <string>

#include "client/lib/map_client.h"
#include "server/semmap_server.h"
#include "server/serialization/conversions.h"
#include "tests/testing/synthetic_frames.h"

namespace semmap::testing {

// semmapd in this process on 127.0.0.1:<any port> over `data_dir`, and a client of it.
struct InProcessServer {
  std::unique_ptr<SemmapServer> server;
  std::unique_ptr<MapClient> client;
};
inline StatusOr<InProcessServer> StartInProcessServer(ServerOptions options,
                                                      const std::string& data_dir) {
  options.listen = "127.0.0.1:0";
  options.data_dir = data_dir;
  InProcessServer out;
  SEMMAP_ASSIGN_OR_RETURN(out.server, SemmapServer::Start(options));
  ClientOptions client_options;
  client_options.server = out.server->address();
  out.client = std::make_unique<MapClient>(client_options);
  return out;
}

inline v1::IngestStart KnownPosesStart(const std::string& map, const std::string& session,
                                       int width = 160, int height = 120) {
  v1::IngestStart start;
  start.set_map(map);
  start.set_session(session);
  start.set_mode(v1::SESSION_MODE_KNOWN_POSES);
  ToProto(TestCamera(width, height), start.mutable_camera());
  return start;
}

// A frame with PNG colour + raw 16UC1 depth and a pose prior.
inline v1::Frame MakeFrame(uint64_t seq, const Eigen::Isometry3d& T_world_camera, int width = 160,
                           int height = 120) {
  v1::Frame frame;
  frame.set_seq(seq);
  ToProto(static_cast<int64_t>(1'000'000'000LL + seq * 33'333'333LL), frame.mutable_timestamp());
  frame.mutable_colour()->mutable_compressed()->set_format("png");
  frame.mutable_colour()->mutable_compressed()->set_data(
      EncodePng(TexturedImage(width, height, static_cast<int>(seq % 7))));
  const cv::Mat depth = PlaneDepth(width, height);
  v1::RawImage* raw = frame.mutable_depth()->mutable_image()->mutable_raw();
  raw->set_width(width);
  raw->set_height(height);
  raw->set_encoding("16UC1");
  raw->set_step(width * 2);
  raw->set_data(std::string(reinterpret_cast<const char*>(depth.data), depth.total() * 2));
  frame.mutable_depth()->set_depth_scale(5000);
  ToProto(T_world_camera, frame.mutable_pose_prior());
  return frame;
}

}  // namespace semmap::testing
