// Turns client images into OpenCV matrices, validating everything a client can get wrong.
#pragma once

#include <opencv2/core/mat.hpp>

#include "common/map_types.h"
#include "common/status.h"
#include "core/sensor/image_message.h"

namespace semmap {

// Colour as BGR8 (or mono8 for grey input), checked against the expected size.
StatusOr<cv::Mat> DecodeColour(const ImageMessage& image, int expected_width, int expected_height);

struct DecodedDepth {
  cv::Mat raw;  // CV_16UC1 in units of 1/depth_scale metres
  double depth_scale = 0;
};
// Depth as 16-bit units; 32FC1 metres are converted at 1/5000 m resolution.
StatusOr<DecodedDepth> DecodeDepth(const DepthMessage& depth, int expected_width,
                                   int expected_height);

// Encoded forms for storage: keep the client's compressed bytes when they are already png/jpeg,
// otherwise encode (JPEG q95 for colour, fast PNG for depth).
StatusOr<EncodedImage> EncodeColourForStorage(const ImageMessage& original, const cv::Mat& bgr);
StatusOr<EncodedImage> EncodeDepthForStorage(const DepthMessage& original,
                                             const DecodedDepth& depth);

}  // namespace semmap
