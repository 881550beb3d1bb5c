#include "client/datasets/image_file.h"

#include <cstdint>
#include <filesystem>
#include <fstream>
#include <system_error>

#include "client/datasets/text_parse.h"

namespace semmap {
namespace {

constexpr std::string_view kPngSignature("\x89PNG\r\n\x1a\n", 8);
constexpr std::string_view kJpegSignature("\xff\xd8\xff", 3);
constexpr size_t kPngHeaderSize = 24;  // signature 8 + chunk length 4 + "IHDR" 4 + w 4 + h 4

uint32_t BigEndian32(std::string_view bytes) {
  uint32_t v = 0;
  for (size_t i = 0; i < 4; ++i) v = (v << 8) | static_cast<uint8_t>(bytes[i]);
  return v;
}

}  // namespace

StatusOr<EncodedFile> ReadImageFile(const std::string& path) {
  SEMMAP_ASSIGN_OR_RETURN(std::string bytes, datasets_internal::ReadWholeFile(path));
  EncodedFile file;
  if (bytes.starts_with(kPngSignature)) {
    file.format = "png";
  } else if (bytes.starts_with(kJpegSignature)) {
    file.format = "jpeg";
  } else {
    return InvalidArgumentError(path + ": not a PNG or JPEG file (" + std::to_string(bytes.size()) +
                                " bytes, unknown magic number)");
  }
  file.bytes = std::move(bytes);
  return file;
}

StatusOr<std::pair<int, int>> PngSize(std::string_view bytes) {
  if (bytes.size() < kPngHeaderSize || !bytes.starts_with(kPngSignature)) {
    return InvalidArgumentError("not a PNG file");
  }
  if (BigEndian32(bytes.substr(8)) != 13 || bytes.substr(12, 4) != "IHDR") {
    return InvalidArgumentError("PNG does not start with an IHDR chunk");
  }
  const uint32_t width = BigEndian32(bytes.substr(16));
  const uint32_t height = BigEndian32(bytes.substr(20));
  // The PNG spec limits both to 1..2^31-1, which also keeps them in an int.
  if (width == 0 || height == 0 || width > 0x7fffffffu || height > 0x7fffffffu) {
    return InvalidArgumentError("PNG size " + std::to_string(width) + "x" + std::to_string(height) +
                                " is invalid");
  }
  return std::make_pair(static_cast<int>(width), static_cast<int>(height));
}

StatusOr<std::pair<int, int>> PngFileSize(const std::string& path) {
  std::error_code ec;
  if (!std::filesystem::exists(path, ec)) return NotFoundError(path + ": no such file");
  std::ifstream in(path, std::ios::binary);
  if (!in) return UnavailableError(path + ": cannot open");
  std::string header(kPngHeaderSize, '\0');
  in.read(header.data(), static_cast<std::streamsize>(header.size()));
  header.resize(static_cast<size_t>(in.gcount()));
  StatusOr<std::pair<int, int>> size = PngSize(header);
  if (!size.ok()) return size.status().WithContext(path);
  return size;
}

}  // namespace semmap
