// Images a hostile client sends: complete, valid PNGs that claim far more pixels than their bytes
// (decompression bombs), and cut-off encodings.
#pragma once

#include <cstdint>
#include <string>

namespace semmap::testing {

// A complete, valid 8-bit greyscale PNG of width x height black pixels, deflated while it is
// written (no width x height buffer): 20000 x 20000 is about 400 kB of file for 400 MB of pixels.
std::string PngBomb(uint32_t width, uint32_t height);

// The first `fraction` of the bytes.
std::string Truncated(const std::string& bytes, double fraction);

}  // namespace semmap::testing
