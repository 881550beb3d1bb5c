// Helpers that write small hand-made datasets into a temp dir for the dataset reader tests.
#pragma once

#include <filesystem>
#include <fstream>
#include <string>

namespace semmap::testing {

inline void WriteFile(const std::string& path, const std::string& content) {
  std::filesystem::create_directories(std::filesystem::path(path).parent_path());
  std::ofstream(path, std::ios::binary) << content;
}

// The first 24 bytes of a PNG (signature + IHDR length, type, width, height): all that the
// readers look at. Not a decodable image.
inline std::string PngHeader(uint32_t width, uint32_t height) {
  std::string bytes("\x89PNG\r\n\x1a\n\0\0\0\x0dIHDR", 16);
  for (uint32_t v : {width, height}) {
    for (int shift = 24; shift >= 0; shift -= 8) bytes.push_back(static_cast<char>(v >> shift));
  }
  return bytes;
}

inline constexpr char kCameraYaml[] =
    "# test camera\n"
    "width: 640\n"
    "height: 480\n"
    "fx: 525.0   # focal\n"
    "fy: 525.0\n"
    "cx: 319.5\n"
    "cy: 239.5\n"
    "depth_scale: 5000\n"
    "distortion: [0.1, -0.2, 0.001, 0.002, 0.05]\n";

}  // namespace semmap::testing
