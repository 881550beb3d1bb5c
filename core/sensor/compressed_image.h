// PNG and JPEG decoding for bytes that come from outside (clients, stored keyframes, object
// photos), with libpng and libjpeg directly rather than cv::imdecode, for two reasons:
//  - the header is read first, so a caller can refuse an image whose size does not fit before
//    a single pixel is allocated (a 425 kB PNG can claim 20000 x 20000 pixels);
//  - every decoder error and every corrupt-data warning is an error: a truncated PNG or JPEG,
//    a bad CRC, missing image data or a premature end are refused, never half-decoded (OpenCV
//    hands back the rows it could read and fills the rest).
#pragma once

#include <cstdint>
#include <opencv2/core/mat.hpp>
#include <string>
#include <string_view>

#include "common/status.h"

namespace semmap {

enum class CompressedFormat { kPng, kJpeg };
std::string_view CompressedFormatName(CompressedFormat format);  // "png", "jpeg"

// What the header says, before any pixel is decoded.
struct CompressedImageInfo {
  CompressedFormat format = CompressedFormat::kPng;
  uint32_t width = 0;
  uint32_t height = 0;
  int channels = 0;   // as stored: 1 grey, 2 grey + alpha, 3 colour, 4 colour + alpha (PNG
                      // palettes count as 3, or 4 with transparency); JPEG 1, 3 or 4 (CMYK)
  int bit_depth = 0;  // bits per sample: 8 or 16 (PNG 1, 2, 4 are reported as 8)
};

// Identifies the format by its signature and reads the header. INVALID_ARGUMENT for bytes that
// are neither PNG nor JPEG or whose header is damaged or truncated.
StatusOr<CompressedImageInfo> ProbeCompressedImage(std::string_view bytes);

// What the caller wants decoded.
enum class DecodeTarget {
  kColour,   // 8-bit: CV_8UC1 for grey images, CV_8UC3 BGR otherwise (alpha dropped)
  kBgr,      // 8-bit CV_8UC3 BGR whatever was stored (grey is expanded)
  kDepth16,  // CV_16UC1: 16-bit single-channel PNG only
};

// Decodes the whole image. `info` must come from ProbeCompressedImage on the same bytes (the
// caller checks the size in it first). INVALID_ARGUMENT with the decoder's reason for anything
// not fully decodable (truncated, corrupt, a sample depth or colour model the target does not
// take); RESOURCE_EXHAUSTED when the pixels cannot be allocated.
StatusOr<cv::Mat> DecodeCompressedImage(std::string_view bytes, const CompressedImageInfo& info,
                                        DecodeTarget target);

}  // namespace semmap
