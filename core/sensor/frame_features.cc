#include "core/sensor/frame_features.h"

#include <algorithm>

namespace semmap {

size_t FrameFeatures::NumWithDepth() const {
  return static_cast<size_t>(std::count(has_depth.begin(), has_depth.end(), true));
}

}  // namespace semmap
