#include "tests/testing/hostile_images.h"

#include <zlib.h>

#include <array>
#include <vector>

namespace semmap::testing {
namespace {

void PutU32(std::string& out, uint32_t v) {
  for (int shift = 24; shift >= 0; shift -= 8)
    out.push_back(static_cast<char>((v >> shift) & 0xff));
}

void PutChunk(std::string& out, const char type[4], const std::string& data) {
  PutU32(out, static_cast<uint32_t>(data.size()));
  std::string body(type, 4);
  body += data;
  out += body;
  PutU32(out, static_cast<uint32_t>(crc32(0, reinterpret_cast<const Bytef*>(body.data()),
                                          static_cast<uInt>(body.size()))));
}

}  // namespace

std::string PngBomb(uint32_t width, uint32_t height) {
  std::string png("\x89PNG\r\n\x1a\n", 8);
  std::string ihdr;
  PutU32(ihdr, width);
  PutU32(ihdr, height);
  ihdr += std::string("\x08\x00\x00\x00\x00", 5);  // 8-bit grey, deflate, no filter, no interlace
  PutChunk(png, "IHDR", ihdr);

  z_stream z{};
  deflateInit(&z, Z_BEST_COMPRESSION);
  const std::vector<Bytef> row(static_cast<size_t>(width) + 1, 0);  // filter byte 0, black
  std::string idat;
  std::array<Bytef, 1 << 16> out{};
  for (uint32_t r = 0; r <= height; ++r) {
    const bool last = r == height;
    z.next_in = const_cast<Bytef*>(row.data());
    z.avail_in = last ? 0 : static_cast<uInt>(row.size());
    do {
      z.next_out = out.data();
      z.avail_out = static_cast<uInt>(out.size());
      deflate(&z, last ? Z_FINISH : Z_NO_FLUSH);
      idat.append(reinterpret_cast<const char*>(out.data()), out.size() - z.avail_out);
    } while (z.avail_out == 0);
  }
  deflateEnd(&z);
  PutChunk(png, "IDAT", idat);
  PutChunk(png, "IEND", "");
  return png;
}

std::string Truncated(const std::string& bytes, double fraction) {
  return bytes.substr(0, static_cast<size_t>(static_cast<double>(bytes.size()) * fraction));
}

}  // namespace semmap::testing
