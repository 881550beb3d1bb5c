// Images as they arrive from a client, before decoding (no protobuf types in the core).
#pragma once

#include <cstdint>
#include <string>

namespace semmap {

struct ImageMessage {
  enum class Kind { kRaw, kCompressed };
  Kind kind = Kind::kRaw;
  // kRaw: "rgb8" | "bgr8" | "mono8" | "16UC1" | "32FC1"; kCompressed: "png" | "jpeg".
  std::string encoding;
  uint32_t width = 0;  // kRaw only
  uint32_t height = 0;
  uint32_t step = 0;
  std::string data;
};

struct DepthMessage {
  ImageMessage image;
  double depth_scale = 0;  // raw units per metre for 16-bit depth; ignored for 32FC1
};

}  // namespace semmap
