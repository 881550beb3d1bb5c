// Image decoding of client and stored bytes (core/sensor): PNG / JPEG headers and pixels, and
// raw images with client-given sizes. The first input byte picks what is decoded; the rest is
// the image. Whatever decodes has the size its header claimed; nothing decodes that is larger
// than the camera it is checked against; every failure is INVALID_ARGUMENT (or
// RESOURCE_EXHAUSTED for memory), never a crash. PNGs also go through both PNG decoders: what
// the fast path takes, libpng takes too, with the same pixels. A fuzzer cannot compute CRCs or
// zlib streams, so two selector bits let mutations reach the pixels: 64, the input is a PNG's
// filtered rows after a 3-byte header (width, height, layout) and the harness writes the PNG
// around them; 32, the input is a PNG whose chunk CRCs the harness recomputes.
#include <array>
#include <cstdint>
#include <cstring>
#include <opencv2/core.hpp>
#include <optional>
#include <string>

#include "core/sensor/compressed_image.h"
#include "core/sensor/image_decoding.h"
#include "core/sensor/internal/png_decoders.h"
#include "tests/fuzz/fuzz_util.h"
#include "tests/testing/png_bytes.h"

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

// Width, height and layout from the first 3 bytes, then filtered rows (filter byte included) as
// the rest gives them, padded with zeros or cut to the image's size; written as a valid PNG.
std::string PngAroundRows(std::string_view bytes) {
  if (bytes.size() < 3) return {};
  static constexpr std::array<std::array<uint8_t, 2>, 6> kLayouts = {
      {{8, 0}, {16, 0}, {8, 2}, {8, 6}, {16, 2}, {8, 4}}};  // bit depth, colour type
  testing::PngLayout layout;
  layout.width = 1 + static_cast<uint8_t>(bytes[0]) % 64;
  layout.height = 1 + static_cast<uint8_t>(bytes[1]) % 64;
  const auto& [depth, type] = kLayouts[static_cast<uint8_t>(bytes[2]) % kLayouts.size()];
  layout.bit_depth = depth;
  layout.colour_type = type;
  const uint32_t channels = type == 0 ? 1 : type == 2 ? 3 : type == 4 ? 2 : 4;
  std::string rows(bytes.substr(3));
  rows.resize(layout.height * (1 + layout.width * channels * layout.bit_depth / 8), '\0');
  return testing::PngFromFilteredRows(layout, rows);
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
  if (info->format == CompressedFormat::kPng) {
    std::optional<cv::Mat> fast = sensor_internal::DecodePngFast(bytes, *info, target);
    if (fast) {
      StatusOr<cv::Mat> reference = sensor_internal::DecodePngWithLibpng(bytes, *info, target);
      FUZZ_CHECK(reference.ok());
      FUZZ_CHECK(reference->type() == fast->type() && reference->size() == fast->size());
      FUZZ_CHECK(cv::norm(*reference, *fast, cv::NORM_INF) == 0);
    }
  }
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
    if (selector & 64) {
      Compressed(PngAroundRows(bytes), selector);
    } else if (selector & 32) {
      Compressed(testing::WithPngCrcsFixed(bytes), selector);
    } else {
      Compressed(bytes, selector);
    }
  } else {
    Raw(bytes, selector);
  }
  return 0;
}
