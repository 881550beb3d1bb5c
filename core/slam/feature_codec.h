// Binary form of a keyframe's features (keypoints, descriptors, 3D points) as stored beside the
// keyframe, so a restarted server can relocalise against and close loops with old keyframes.
#pragma once

#include <string>
#include <string_view>

#include "common/status.h"
#include "core/sensor/frame_features.h"

namespace semmap {

inline constexpr std::string_view kFeatureCodecFormat = "semmap-features-v1";

// Little-endian fixed-width fields; lossless for keypoints (float) and descriptors, 3D points
// as float (sub-micrometre at indoor ranges).
std::string EncodeFeatures(const FrameFeatures& features);
// DATA_LOSS for truncated or inconsistent bytes, INVALID_ARGUMENT for another format.
StatusOr<FrameFeatures> DecodeFeatures(std::string_view format, std::string_view bytes);

}  // namespace semmap
