// The two PNG decoders behind DecodeCompressedImage (compressed_image.h).
//
// Decoding dominated the server's CPU per RGB-D frame (about 10 of 14 ms for a TUM colour PNG,
// 8 of them in libpng's row filters), so PNGs of the layouts cameras and datasets write are
// decoded by a fast path: the zlib stream inflated in one call by libdeflate, the row filters
// undone here, the channels reordered by OpenCV. Everything else -- another layout, an
// interlaced image, any chunk we do not expect, any damage at all -- is left to libpng, which
// gives the verdict and the error message. So the fast path never accepts what libpng would
// refuse, and where both decode, the pixels are the same (the image_decode fuzz target checks
// both on every input).
#pragma once

#include <opencv2/core/mat.hpp>
#include <optional>
#include <string_view>

#include "common/status.h"
#include "core/sensor/compressed_image.h"

namespace semmap::sensor_internal {

// The fast path. Takes a non-interlaced PNG of 8-bit grey, RGB or RGBA, or 16-bit grey, with
// only IHDR, IDAT, IEND and text, time and pHYs chunks, every CRC and the zlib checksum
// right and exactly the image's bytes in the stream. nullopt for anything else (including a
// target the image does not suit, or no memory): then use DecodePngWithLibpng. `info` must come
// from ProbeCompressedImage on the same bytes.
std::optional<cv::Mat> DecodePngFast(std::string_view bytes, const CompressedImageInfo& info,
                                     DecodeTarget target);

// libpng: every layout PNG has, every error refused with its reason.
StatusOr<cv::Mat> DecodePngWithLibpng(std::string_view bytes, const CompressedImageInfo& info,
                                      DecodeTarget target);

}  // namespace semmap::sensor_internal
