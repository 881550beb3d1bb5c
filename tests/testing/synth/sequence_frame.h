// One frame of a synthetic sequence with its sensor effects: motion blur (colour rendered at
// poses spread over the exposure, interpolated towards the neighbouring frames), then depth
// noise, dropped depth and colour noise. Each frame's randomness comes from (seed, index), so
// any frame can be rendered alone and a sequence is the same in any order.
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

#include "client/datasets/trajectory_io.h"
#include "tests/testing/synth/noise.h"
#include "tests/testing/synth/renderer.h"

namespace semmap::synth {

// `noise` must pass ValidateNoiseOptions; an index past the trajectory gives empty images. The
// exposure is centred on the frame's pose, which stays the ground truth.
RenderedFrame RenderSequenceFrame(const Renderer& renderer,
                                  const std::vector<StampedPose>& trajectory, size_t index,
                                  const NoiseOptions& noise, uint64_t seed);

}  // namespace semmap::synth
