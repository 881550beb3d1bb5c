// PNG bytes written by hand, for the PNG decoder tests and the image_decode fuzz target: chunks
// with their CRCs, a file around rows that are already filtered (the zlib stream by libdeflate),
// and CRCs made right again after a test or the fuzzer changed bytes. Header-only, so the fuzz
// target needs no more than libdeflate (which both link).
#pragma once

#include <libdeflate.h>

#include <algorithm>
#include <cstdint>
#include <string>
#include <string_view>

namespace semmap::testing {

inline void AppendBigEndian32(std::string& out, uint32_t v) {
  for (int shift = 24; shift >= 0; shift -= 8) out.push_back(static_cast<char>(v >> shift));
}

inline void AppendPngChunk(std::string& out, std::string_view type, std::string_view data) {
  AppendBigEndian32(out, static_cast<uint32_t>(data.size()));
  const size_t body = out.size();
  out += type;
  out += data;
  AppendBigEndian32(
      out, static_cast<uint32_t>(libdeflate_crc32(0, out.data() + body, out.size() - body)));
}

struct PngLayout {
  uint32_t width = 0;
  uint32_t height = 0;
  uint8_t bit_depth = 8;
  uint8_t colour_type = 2;  // 0 grey, 2 RGB, 4 grey + alpha, 6 RGBA
};

// A non-interlaced PNG of `filtered` (each row's filter byte, then its bytes; taken as given)
// with the zlib stream split over `idat_chunks` IDAT chunks, and `before_idat` / `after_idat`
// (chunks already framed) around them. Empty when libdeflate has no memory.
inline std::string PngFromFilteredRows(const PngLayout& layout, std::string_view filtered,
                                       size_t idat_chunks = 1, std::string_view before_idat = {},
                                       std::string_view after_idat = {}) {
  libdeflate_compressor* compressor = libdeflate_alloc_compressor(1);
  if (compressor == nullptr) return {};
  std::string stream(libdeflate_zlib_compress_bound(compressor, filtered.size()), '\0');
  stream.resize(libdeflate_zlib_compress(compressor, filtered.data(), filtered.size(),
                                         stream.data(), stream.size()));
  libdeflate_free_compressor(compressor);
  std::string png("\x89PNG\r\n\x1a\n", 8), header;
  AppendBigEndian32(header, layout.width);
  AppendBigEndian32(header, layout.height);
  header += {static_cast<char>(layout.bit_depth), static_cast<char>(layout.colour_type), 0, 0, 0};
  AppendPngChunk(png, "IHDR", header);
  png += before_idat;
  const size_t piece = stream.size() / std::max<size_t>(idat_chunks, 1) + 1;
  for (size_t i = 0; i < std::max<size_t>(idat_chunks, 1); ++i) {
    const size_t begin = std::min(stream.size(), i * piece);
    AppendPngChunk(png, "IDAT", std::string_view(stream).substr(begin, piece));
  }
  png += after_idat;
  AppendPngChunk(png, "IEND", "");
  return png;
}

// The same bytes with every complete chunk's CRC made right (the 8-byte signature is left as
// it is; a chunk running past the end stops the walk).
inline std::string WithPngCrcsFixed(std::string_view bytes) {
  std::string out(bytes);
  for (size_t at = 8; at + 12 <= out.size();) {
    const auto* p = reinterpret_cast<const uint8_t*>(out.data() + at);
    const uint64_t length =
        (uint64_t{p[0]} << 24) | (uint64_t{p[1]} << 16) | (uint64_t{p[2]} << 8) | p[3];
    if (length > out.size() - at - 12) break;
    const auto crc = static_cast<uint32_t>(libdeflate_crc32(0, out.data() + at + 4, length + 4));
    for (int i = 0; i < 4; ++i) out[at + 8 + length + i] = static_cast<char>(crc >> (24 - 8 * i));
    at += 12 + length;
  }
  return out;
}

}  // namespace semmap::testing
