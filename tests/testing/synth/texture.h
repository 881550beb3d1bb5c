// Procedural, non-repeating textures for the synthetic scene. Each texture is a "dead leaves"
// collage: random shapes (polygons, ellipses, bars, rings, small checkers, words) at many
// scales over a smooth colour field, so corner detectors such as ORB's FAST find many
// keypoints at every pyramid level, and no two patches, nor two textures of different seeds,
// look alike (a wall seen twice matches itself, never another wall).
#pragma once

#include <cstdint>
#include <opencv2/core/mat.hpp>
#include <string_view>

#include "common/status.h"

namespace semmap::synth {

// Colour schemes (and shape scales) of the scene's kinds of surface.
enum class TextureStyle {
  kWall,       // one dominant hue per wall, varied lightness
  kFloor,      // warm browns and greys
  kCeiling,    // pale, low saturation
  kFurniture,  // wood-like hues
  kObject,     // saturated colours, bold shapes and a caption (the object's label)
};

// A BGR8 texture of cols x rows texels; deterministic given the arguments. `caption` is
// printed large on kObject textures (ignored for other styles). Sizes must be 8..16384.
StatusOr<cv::Mat> GenerateTexture(int cols, int rows, TextureStyle style, uint64_t seed,
                                  std::string_view caption = {});

}  // namespace semmap::synth
