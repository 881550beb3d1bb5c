// Seeds for the image and wire-message fuzz targets, written with the repo's own code:
//   image_decode    selector byte + small PNGs / JPEGs of every colour model, + raw images
//   ingest_request  serialised IngestRequests: start, frames (PNG colour, raw and PNG depth), end
//   rpc_requests    selector byte + serialised request messages
#include "tests/fuzz/make_wire_seeds.h"

#include <cstring>
#include <fstream>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <string>
#include <vector>

#include "semmap/v1/service.pb.h"
#include "server/serialization/conversions.h"

namespace semmap::fuzz {
namespace {

namespace fs = std::filesystem;

std::string Encode(const cv::Mat& image, const std::string& ext, std::vector<int> params = {}) {
  std::vector<uchar> buf;
  if (!cv::imencode(ext, image, buf, params)) return {};
  return std::string(buf.begin(), buf.end());
}

cv::Mat Pattern(int width, int height) {
  cv::Mat bgr(height, width, CV_8UC3);
  cv::randu(bgr, 0, 255);
  cv::GaussianBlur(bgr, bgr, cv::Size(3, 3), 0);
  return bgr;
}

cv::Mat Depth(int width, int height) {
  cv::Mat depth(height, width, CV_16UC1);
  for (int r = 0; r < height; ++r) {
    for (int c = 0; c < width; ++c) depth.at<uint16_t>(r, c) = static_cast<uint16_t>(5000 + 7 * c);
  }
  return depth;
}

std::string Serialized(const google::protobuf::Message& message) {
  std::string bytes;
  message.SerializeToString(&bytes);
  return bytes;
}

}  // namespace

bool WriteSeedFile(const fs::path& dir, const std::string& name, const std::string& bytes) {
  std::error_code ec;
  fs::create_directories(dir, ec);
  std::ofstream out(dir / name, std::ios::binary | std::ios::trunc);
  out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
  return static_cast<bool>(out);
}

bool ImageSeeds(const fs::path& dir) {
  const cv::Mat bgr = Pattern(24, 16);
  cv::Mat grey, bgra;
  cv::cvtColor(bgr, grey, cv::COLOR_BGR2GRAY);
  cv::cvtColor(bgr, bgra, cv::COLOR_BGR2BGRA);
  const std::string images[][2] = {
      {"colour.png", Encode(bgr, ".png")},
      {"grey.png", Encode(grey, ".png")},
      {"alpha.png", Encode(bgra, ".png")},
      {"depth16.png", Encode(Depth(24, 16), ".png")},
      {"baseline.jpg", Encode(bgr, ".jpg")},
      {"grey.jpg", Encode(grey, ".jpg")},
      {"progressive.jpg", Encode(bgr, ".jpg", {cv::IMWRITE_JPEG_PROGRESSIVE, 1})},
  };
  bool ok = true;
  for (const auto& [name, bytes] : images) {
    if (bytes.empty()) return false;
    // Selector 0..127 picks the compressed path and the target (colour, bgr, depth16).
    for (char selector : {'\x00', '\x01', '\x02'}) {
      ok &= WriteSeedFile(dir, name + "." + std::to_string(static_cast<int>(selector)),
                          std::string(1, selector) + bytes);
    }
  }
  // Raw: selector >= 128 (encoding = selector % 6, own-size camera on odd selector / 6), then
  // width, height, step (little-endian) and the pixels.
  const struct {
    const char* name;
    uint8_t selector;
    int bytes_per_pixel;
  } raws[] = {{"rgb8", 132, 3}, {"mono8", 134, 1}, {"depth16", 129, 2}, {"depth32", 136, 4}};
  for (const auto& raw : raws) {
    const uint32_t width = 64, height = 48, step = width * raw.bytes_per_pixel;
    std::string bytes(1, static_cast<char>(raw.selector));
    for (uint32_t v : {width, height, step}) bytes.append(reinterpret_cast<const char*>(&v), 4);
    bytes.append(static_cast<size_t>(step) * height, '\x10');
    ok &= WriteSeedFile(dir, std::string("raw_") + raw.name, bytes);
  }
  return ok;
}

bool IngestSeeds(const fs::path& dir) {
  CameraCalibration camera;
  camera.width = 24;
  camera.height = 16;
  camera.fx = camera.fy = 20;
  camera.cx = 11.5;
  camera.cy = 7.5;
  v1::IngestRequest start;
  start.mutable_start()->set_map("lab");
  start.mutable_start()->set_session("run1");
  start.mutable_start()->set_mode(v1::SESSION_MODE_KNOWN_POSES);
  ToProto(camera, start.mutable_start()->mutable_camera());
  start.mutable_start()->mutable_keyframes()->set_min_motion(0.1);

  v1::IngestRequest frame;
  v1::Frame* f = frame.mutable_frame();
  f->set_seq(7);
  ToProto(int64_t{1'341'841'873'541'941'000}, f->mutable_timestamp());
  f->mutable_colour()->mutable_compressed()->set_format("png");
  f->mutable_colour()->mutable_compressed()->set_data(Encode(Pattern(24, 16), ".png"));
  const cv::Mat depth = Depth(24, 16);
  v1::RawImage* raw = f->mutable_depth()->mutable_image()->mutable_raw();
  raw->set_width(24);
  raw->set_height(16);
  raw->set_encoding("16UC1");
  raw->set_step(48);
  raw->set_data(std::string(reinterpret_cast<const char*>(depth.data), depth.total() * 2));
  f->mutable_depth()->set_depth_scale(5000);
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.translation() = Eigen::Vector3d(0.1, 0.2, 0.3);
  ToProto(T, f->mutable_pose_prior());

  v1::IngestRequest png_depth = frame;
  png_depth.mutable_frame()->mutable_depth()->mutable_image()->mutable_compressed()->set_format(
      "png");
  png_depth.mutable_frame()->mutable_depth()->mutable_image()->mutable_compressed()->set_data(
      Encode(depth, ".png"));
  v1::IngestRequest jpeg = frame;
  jpeg.mutable_frame()->mutable_colour()->mutable_compressed()->set_format("jpeg");
  jpeg.mutable_frame()->mutable_colour()->mutable_compressed()->set_data(
      Encode(Pattern(24, 16), ".jpg"));
  v1::IngestRequest end;
  end.mutable_end();
  bool ok = WriteSeedFile(dir, "start", Serialized(start));
  ok &= WriteSeedFile(dir, "frame_raw_depth", Serialized(frame));
  ok &= WriteSeedFile(dir, "frame_png_depth", Serialized(png_depth));
  ok &= WriteSeedFile(dir, "frame_jpeg", Serialized(jpeg));
  ok &= WriteSeedFile(dir, "end", Serialized(end));
  return ok;
}

bool RequestSeeds(const fs::path& dir) {
  v1::RegisterObjectRequest reg;
  reg.set_label("teddy");
  reg.set_map("lab");
  v1::CompressedImage* photo = reg.add_photos();
  photo->set_format("png");
  photo->set_data(Encode(Pattern(24, 16), ".png"));
  reg.mutable_colour()->set_r(255);
  v1::ExportMapRequest exp;
  exp.set_map("lab");
  exp.set_format("png");
  exp.set_voxel(0.05);
  exp.set_view("oblique");
  exp.set_width(800);
  v1::ObjectsNearRequest near;
  near.set_map("lab");
  near.mutable_point()->set_x(1);
  near.set_radius(2);
  near.set_label("mug");
  v1::CameraCalibration camera;
  camera.set_width(640);
  camera.set_height(480);
  camera.set_distortion_model("plumb_bob");
  for (double d : {0.1, -0.2, 0.0, 0.0, 0.05}) camera.add_d(d);
  for (double k : {525.0, 0.0, 319.5, 0.0, 525.0, 239.5, 0.0, 0.0, 1.0}) camera.add_k(k);
  v1::Pose pose;
  pose.mutable_position()->set_z(1);
  pose.mutable_orientation()->set_w(1);
  v1::SessionInfo session;
  session.set_map("lab");
  session.set_name("run1");
  session.set_end_reason(v1::SESSION_END_REASON_COMPLETED);
  v1::TrajectoryPose trajectory;
  trajectory.set_seq(3);
  *trajectory.mutable_t_world_camera() = pose;
  v1::RemoveSessionRequest remove;
  remove.set_map("lab");
  remove.set_session("run1");
  const google::protobuf::Message* messages[] = {&reg,  &exp,     &near,       &camera,
                                                 &pose, &session, &trajectory, &remove};
  bool ok = true;
  for (size_t i = 0; i < std::size(messages); ++i) {
    ok &= WriteSeedFile(dir, messages[i]->GetTypeName(),
                        std::string(1, static_cast<char>(i)) + Serialized(*messages[i]));
  }
  return ok;
}

}  // namespace semmap::fuzz
