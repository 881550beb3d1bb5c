// One point of a map's coloured cloud: world coordinates and colour in RGB order (unlike
// KeyframeCloud's BGR). Shared by the cloud layer, its readers and the picture renderer.
#pragma once

#include <cstdint>

namespace semmap {

struct CloudPoint {
  float x = 0;
  float y = 0;
  float z = 0;
  uint8_t r = 0;
  uint8_t g = 0;
  uint8_t b = 0;
};

}  // namespace semmap
