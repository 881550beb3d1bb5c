// Encoded image files, passed through undecoded: the client ships the file's bytes and the
// server decodes them, so the client needs no image codec.
#pragma once

#include <string>
#include <string_view>
#include <utility>

#include "common/status.h"

namespace semmap {

struct EncodedFile {
  std::string format;  // "png" or "jpeg"
  std::string bytes;
};

// Reads a file and identifies it by its magic number (not its extension). NOT_FOUND when the
// file does not exist; INVALID_ARGUMENT naming it when it is neither PNG nor JPEG.
StatusOr<EncodedFile> ReadImageFile(const std::string& path);

// (width, height) from a PNG's signature and IHDR chunk (the first 24 bytes suffice).
StatusOr<std::pair<int, int>> PngSize(std::string_view bytes);

// PngSize of a file, reading only its header.
StatusOr<std::pair<int, int>> PngFileSize(const std::string& path);

}  // namespace semmap
