// The default synthetic room: 6 x 5 x 2.8 m (x in [-3, 3], y in [-2.5, 2.5], z in [0, 2.8]),
// every wall, the floor and the ceiling with its own non-repeating texture (5 mm texels),
// four furniture boxes against the walls (a shelf, a cabinet, a table, a slightly turned sofa;
// 4 mm texels) and four named objects facing the room's centre (1 mm texels):
//   book        a standing book on the cabinet (front cover towards -y)
//   laptop      an open laptop on the table (base + lid leaning back; the screen is the front)
//   mug_poster  a poster on the wall above the sofa
//   teddy_box   a cube on the floor beside the shelf
// The middle of the room (|x| < 2, |y| < 1.4) is free for cameras.
#pragma once

#include <cstdint>

#include "common/status.h"
#include "tests/testing/synth/scene.h"

namespace semmap::synth {

inline constexpr double kRoomTexelM = 0.005;
inline constexpr double kFurnitureTexelM = 0.004;
inline constexpr double kObjectTexelM = 0.001;

// Deterministic given `seed`; different seeds give different textures (same layout).
// Takes about 0.2-0.4 s (texture generation).
StatusOr<Scene> MakeDefaultRoomScene(uint64_t seed);

}  // namespace semmap::synth
