#include "core/sensor/frame_features.h"

#include <algorithm>

namespace semmap {

size_t FrameFeatures::NumWithDepth() const {
  return static_cast<size_t>(std::count(has_depth.begin(), has_depth.end(), true));
}

size_t FrameFeatures::HeldBytes() const {
  return keypoints.capacity() * sizeof(cv::KeyPoint) +
         (descriptors.data != nullptr ? descriptors.total() * descriptors.elemSize() : 0) +
         points_camera.capacity() * sizeof(Eigen::Vector3d) + has_depth.capacity() / 8;
}

}  // namespace semmap
