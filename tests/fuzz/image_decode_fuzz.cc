// Image decoding of client and stored bytes (core/sensor): PNG / JPEG headers and pixels, and
// raw images with client-given sizes. The first input byte picks what is decoded; the rest is
// the image. Whatever decodes has the size its header claimed; nothing decodes that is larger
// than the camera it is checked against; every failure is INVALID_ARGUMENT (or
// RESOURCE_EXHAUSTED for memory), never a crash.
#include <cstdint>
#include <cstring>
#include <string>

#include "core/sensor/compressed_image.h"
#include "core/sensor/image_decoding.h"
#include "tests/fuzz/fuzz_util.h"

namespace {

using namespace semmap;

// A camera the fuzzer can reach quickly; big enough for real seeds (the samples are 640x480).
constexpr int kWidth = 640;
constexpr int kHeight = 480;

void CheckError(const Status& status) {
  FUZZ_CHECK(status.code() == StatusCode::kInvalidArgument ||
             status.code() == StatusCode::kResourceExhausted);
  FUZZ_CHECK(!status.message().empty());
}

void Compressed(std::string_view bytes, uint8_t selector) {
  StatusOr<CompressedImageInfo> info = ProbeCompressedImage(bytes);
  if (!info.ok()) {
    CheckError(info.status());
    return;
  }
  FUZZ_CHECK(info->width > 0 && info->height > 0);
  // Decode only what a caller would: the header's size within the camera's pixel count.
  if (static_cast<uint64_t>(info->width) * info->height > uint64_t{kWidth} * kHeight) return;
  const DecodeTarget targets[] = {DecodeTarget::kColour, DecodeTarget::kBgr,
                                  DecodeTarget::kDepth16};
  const DecodeTarget target = targets[selector % 3];
  StatusOr<cv::Mat> decoded = DecodeCompressedImage(bytes, *info, target);
  if (!decoded.ok()) {
    CheckError(decoded.status());
    return;
  }
  FUZZ_CHECK(decoded->cols == static_cast<int>(info->width));
  FUZZ_CHECK(decoded->rows == static_cast<int>(info->height));
  if (target == DecodeTarget::kDepth16) FUZZ_CHECK(decoded->type() == CV_16UC1);
  if (target == DecodeTarget::kBgr) FUZZ_CHECK(decoded->type() == CV_8UC3);
  if (target == DecodeTarget::kColour) {
    FUZZ_CHECK(decoded->type() == CV_8UC3 || decoded->type() == CV_8UC1);
  }
}

// Raw: 12 header bytes (width, height, step as little-endian uint32), then the pixels.
void Raw(std::string_view bytes, uint8_t selector) {
  if (bytes.size() < 12) return;
  ImageMessage image;
  image.kind = ImageMessage::Kind::kRaw;
  std::memcpy(&image.width, bytes.data(), 4);
  std::memcpy(&image.height, bytes.data() + 4, 4);
  std::memcpy(&image.step, bytes.data() + 8, 4);
  image.data = std::string(bytes.substr(12));
  static const char* const kEncodings[] = {"rgb8", "bgr8", "mono8", "16UC1", "32FC1", "yuv"};
  image.encoding = kEncodings[selector % 6];
  // The camera is the image's own claimed size half of the time (what reaches the size maths).
  const bool own = (selector / 6) % 2 == 1;
  const int w = own && image.width <= 0x7fffffffu ? static_cast<int>(image.width) : 64;
  const int h = own && image.height <= 0x7fffffffu ? static_cast<int>(image.height) : 48;
  if (selector % 6 >= 3) {
    StatusOr<DecodedDepth> depth = DecodeDepth({image, 5000}, w, h);
    if (!depth.ok()) return CheckError(depth.status());
    FUZZ_CHECK(depth->raw.cols == w && depth->raw.rows == h && depth->raw.type() == CV_16UC1);
  } else {
    StatusOr<cv::Mat> colour = DecodeColour(image, w, h);
    if (!colour.ok()) return CheckError(colour.status());
    FUZZ_CHECK(colour->cols == w && colour->rows == h);
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size < 1) return 0;
  const uint8_t selector = data[0];
  const std::string_view bytes = fuzz::AsText(data + 1, size - 1);
  if (selector < 128) {
    Compressed(bytes, selector);
  } else {
    Raw(bytes, selector);
  }
  return 0;
}
