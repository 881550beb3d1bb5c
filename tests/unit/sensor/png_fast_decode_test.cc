// The PNG fast path (core/sensor/internal/png_fast_decode.cc) against libpng and against the
// pixels that were encoded: every row filter for every pixel size it takes, real dataset
// files, and every kind of damage or surprise left to libpng rather than decoded.
#include <gtest/gtest.h>

#include <array>
#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>
#include <sstream>
#include <string>
#include <vector>

#include "core/sensor/compressed_image.h"
#include "core/sensor/internal/png_decoders.h"
#include "tests/testing/png_bytes.h"

namespace semmap {
namespace {

using sensor_internal::DecodePngFast;
using sensor_internal::DecodePngWithLibpng;

using testing::AppendPngChunk;

int PaethPredictor(int a, int b, int c) {
  const int p = a + b - c;
  const int pa = std::abs(p - a), pb = std::abs(p - b), pc = std::abs(p - c);
  if (pa <= pb && pa <= pc) return a;
  return pb <= pc ? b : c;
}

// Filters one row (PNG spec section 9, the encoder's side) with `type`.
std::string FilterRow(int type, const uint8_t* row, const uint8_t* prev, size_t n, size_t bpp) {
  std::string out(1, static_cast<char>(type));
  for (size_t i = 0; i < n; ++i) {
    const int a = i >= bpp ? row[i - bpp] : 0, b = prev[i], c = i >= bpp ? prev[i - bpp] : 0;
    int predicted = 0;
    if (type == 1) predicted = a;
    if (type == 2) predicted = b;
    if (type == 3) predicted = (a + b) / 2;
    if (type == 4) predicted = PaethPredictor(a, b, c);
    out.push_back(static_cast<char>(static_cast<uint8_t>(row[i] - predicted)));
  }
  return out;
}

struct PngSpec {
  int bit_depth = 8;
  int colour_type = 2;                         // 0 grey, 2 RGB, 6 RGBA
  std::vector<int> filters = {0, 1, 2, 3, 4};  // row r uses filters[r % size]
  size_t idat_chunks = 1;                      // the stream split into this many IDAT chunks
  std::string before_idat, after_idat;         // extra chunks, already framed
};

// `samples` (PNG byte order: RGB(A), 16-bit big-endian; one row after another) filtered with
// spec.filters, each row after its filter byte.
std::string FilterRows(const std::vector<uint8_t>& samples, int width, int height,
                       const PngSpec& spec) {
  const size_t channels = spec.colour_type == 0 ? 1 : spec.colour_type == 2 ? 3 : 4;
  const size_t bpp = channels * static_cast<size_t>(spec.bit_depth / 8);
  const size_t row_bytes = bpp * static_cast<size_t>(width);
  std::string filtered;
  const std::vector<uint8_t> zeros(row_bytes, 0);
  for (int r = 0; r < height; ++r) {
    const uint8_t* row = samples.data() + static_cast<size_t>(r) * row_bytes;
    const uint8_t* prev = r == 0 ? zeros.data() : row - row_bytes;
    filtered += FilterRow(spec.filters[static_cast<size_t>(r) % spec.filters.size()], row, prev,
                          row_bytes, bpp);
  }
  return filtered;
}

testing::PngLayout LayoutOf(int width, int height, const PngSpec& spec) {
  return {static_cast<uint32_t>(width), static_cast<uint32_t>(height),
          static_cast<uint8_t>(spec.bit_depth), static_cast<uint8_t>(spec.colour_type)};
}

std::string BuildPng(const std::vector<uint8_t>& samples, int width, int height,
                     const PngSpec& spec) {
  return testing::PngFromFilteredRows(LayoutOf(width, height, spec),
                                      FilterRows(samples, width, height, spec), spec.idat_chunks,
                                      spec.before_idat, spec.after_idat);
}

std::vector<uint8_t> RandomSamples(size_t n, int seed) {
  cv::Mat noise(1, static_cast<int>(n), CV_8UC1);
  cv::RNG rng(static_cast<uint64_t>(seed));
  rng.fill(noise, cv::RNG::UNIFORM, 0, 256);
  // Smooth half of it so the predictors see both noise and gradients.
  std::vector<uint8_t> out(noise.data, noise.data + n);
  for (size_t i = n / 2; i < n; ++i) out[i] = static_cast<uint8_t>((i * 7 + out[i] / 16) & 0xff);
  return out;
}

CompressedImageInfo Probe(const std::string& bytes) {
  StatusOr<CompressedImageInfo> info = ProbeCompressedImage(bytes);
  EXPECT_TRUE(info.ok()) << info.status().ToString();
  return info.ok() ? *info : CompressedImageInfo{};
}

// Both decoders give the same pixels and the fast path takes the file.
void ExpectFastMatchesLibpng(const std::string& bytes, DecodeTarget target,
                             const std::string& what) {
  const CompressedImageInfo info = Probe(bytes);
  StatusOr<cv::Mat> reference = DecodePngWithLibpng(bytes, info, target);
  ASSERT_TRUE(reference.ok()) << what << ": " << reference.status().ToString();
  std::optional<cv::Mat> fast = DecodePngFast(bytes, info, target);
  ASSERT_TRUE(fast.has_value()) << what << ": the fast path left it to libpng";
  ASSERT_EQ(fast->type(), reference->type()) << what;
  ASSERT_EQ(fast->size(), reference->size()) << what;
  EXPECT_EQ(cv::norm(*fast, *reference, cv::NORM_INF), 0) << what;
}

TEST(PngFastDecodeTest, EveryFilterAndPixelSizeMatchesLibpngAndTheSamples) {
  struct Case {
    int bit_depth, colour_type;
    std::vector<DecodeTarget> targets;
  };
  const std::vector<Case> cases = {
      {8, 0, {DecodeTarget::kColour, DecodeTarget::kBgr}},
      {16, 0, {DecodeTarget::kDepth16}},
      {8, 2, {DecodeTarget::kColour, DecodeTarget::kBgr}},
      {8, 6, {DecodeTarget::kColour, DecodeTarget::kBgr}},
  };
  for (const Case& c : cases) {
    for (int filter = 0; filter <= 4; ++filter) {
      for (const auto& [w, h] : std::vector<std::pair<int, int>>{{37, 23}, {1, 5}, {4, 1}}) {
        PngSpec spec;
        spec.bit_depth = c.bit_depth;
        spec.colour_type = c.colour_type;
        spec.filters = {filter};
        const size_t channels = c.colour_type == 0 ? 1 : c.colour_type == 2 ? 3 : 4;
        const size_t bpp = channels * static_cast<size_t>(c.bit_depth / 8);
        const std::vector<uint8_t> samples =
            RandomSamples(bpp * static_cast<size_t>(w * h), filter + w);
        const std::string png = BuildPng(samples, w, h, spec);
        for (DecodeTarget target : c.targets) {
          const std::string what =
              "depth " + std::to_string(c.bit_depth) + " type " + std::to_string(c.colour_type) +
              " filter " + std::to_string(filter) + " " + std::to_string(w) + "x" +
              std::to_string(h) + " target " + std::to_string(static_cast<int>(target));
          ExpectFastMatchesLibpng(png, target, what);
          // And the pixels are the samples, in OpenCV's layout.
          std::optional<cv::Mat> fast = DecodePngFast(png, Probe(png), target);
          ASSERT_TRUE(fast.has_value()) << what;
          for (int r = 0; r < h; ++r) {
            for (int x = 0; x < w; ++x) {
              const uint8_t* s = samples.data() + (static_cast<size_t>(r * w + x)) * bpp;
              if (target == DecodeTarget::kDepth16) {
                ASSERT_EQ(fast->at<uint16_t>(r, x), (s[0] << 8) | s[1]) << what;
              } else if (c.colour_type == 0 && target == DecodeTarget::kColour) {
                ASSERT_EQ(fast->at<uint8_t>(r, x), s[0]) << what;
              } else if (c.colour_type == 0) {
                ASSERT_EQ(fast->at<cv::Vec3b>(r, x), cv::Vec3b(s[0], s[0], s[0])) << what;
              } else {
                ASSERT_EQ(fast->at<cv::Vec3b>(r, x), cv::Vec3b(s[2], s[1], s[0])) << what;
              }
            }
          }
        }
      }
    }
  }
}

TEST(PngFastDecodeTest, MixedFiltersSplitStreamsAndTextChunksAreTaken) {
  PngSpec spec;
  spec.filters = {4, 1, 0, 3, 2, 4, 4};
  spec.idat_chunks = 9;  // some of them empty once the stream is split this finely
  AppendPngChunk(spec.before_idat, "tEXt", std::string("Software\0test", 13));
  AppendPngChunk(spec.after_idat, "tIME", std::string("\x07\xea\x0c\x06\x05\x00\x00", 7));
  const std::string png = BuildPng(RandomSamples(3 * 64 * 48, 3), 64, 48, spec);
  ExpectFastMatchesLibpng(png, DecodeTarget::kColour, "mixed");
  // The public entry point takes the same pixels.
  StatusOr<cv::Mat> decoded = DecodeCompressedImage(png, Probe(png), DecodeTarget::kColour);
  ASSERT_TRUE(decoded.ok()) << decoded.status().ToString();
}

std::string ReadFile(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream buffer;
  buffer << in.rdbuf();
  return buffer.str();
}

TEST(PngFastDecodeTest, RealDatasetFilesMatchLibpng) {
  const std::filesystem::path teddy =
      std::filesystem::path(SEMMAP_SHARED_DATA_DIR) / "tum_fr3_teddy_200";
  if (!std::filesystem::exists(teddy / "rgb")) {
    GTEST_SKIP() << teddy << " absent (../shared/data): real-file comparison skipped";
  }
  for (const char* kind : {"rgb", "depth"}) {
    std::vector<std::filesystem::path> files;
    for (const auto& entry : std::filesystem::directory_iterator(teddy / kind)) {
      files.push_back(entry.path());
    }
    std::sort(files.begin(), files.end());
    for (size_t i = 0; i < files.size(); i += 25) {
      const DecodeTarget target =
          std::string(kind) == "rgb" ? DecodeTarget::kColour : DecodeTarget::kDepth16;
      ExpectFastMatchesLibpng(ReadFile(files[i]), target, files[i].string());
    }
  }
}

// Takes the PNG apart into chunks (offset of each chunk's length field) for the damage tests.
std::vector<size_t> ChunkOffsets(const std::string& png) {
  std::vector<size_t> out;
  for (size_t at = 8; at + 12 <= png.size();) {
    out.push_back(at);
    const auto* p = reinterpret_cast<const uint8_t*>(png.data() + at);
    at += 12 + ((size_t{p[0]} << 24) | (size_t{p[1]} << 16) | (size_t{p[2]} << 8) | p[3]);
  }
  return out;
}

// The fast path declines; the public decoder then answers as libpng does.
void ExpectLeftToLibpng(const std::string& png, DecodeTarget target, const std::string& what) {
  StatusOr<CompressedImageInfo> info = ProbeCompressedImage(png);
  if (!info.ok()) return;  // refused before any decoder runs
  EXPECT_FALSE(DecodePngFast(png, *info, target).has_value()) << what;
  StatusOr<cv::Mat> reference = DecodePngWithLibpng(png, *info, target);
  StatusOr<cv::Mat> decoded = DecodeCompressedImage(png, *info, target);
  ASSERT_EQ(decoded.ok(), reference.ok()) << what;
  if (reference.ok()) {
    EXPECT_EQ(cv::norm(*decoded, *reference, cv::NORM_INF), 0) << what;
  } else {
    EXPECT_EQ(decoded.status().message(), reference.status().message()) << what;
  }
}

TEST(PngFastDecodeTest, DamageAndSurprisesAreLeftToLibpng) {
  PngSpec spec;
  spec.filters = {4, 1};
  const std::string good = BuildPng(RandomSamples(3 * 40 * 30, 9), 40, 30, spec);
  ExpectFastMatchesLibpng(good, DecodeTarget::kColour, "good");
  const std::vector<size_t> chunks = ChunkOffsets(good);  // IHDR, IDAT, IEND
  ASSERT_EQ(chunks.size(), 3u);
  const size_t ihdr = chunks[0], idat = chunks[1];

  std::string bad_crc = good;
  bad_crc[idat + 8 + 20] ^= 0x40;  // data changed, CRC not
  ExpectLeftToLibpng(bad_crc, DecodeTarget::kColour, "IDAT CRC wrong");

  const std::string bad_stream = testing::WithPngCrcsFixed(bad_crc);  // zlib stream damaged
  ExpectLeftToLibpng(bad_stream, DecodeTarget::kColour, "zlib stream damaged");

  std::string interlaced = good;
  interlaced[ihdr + 8 + 12] = 1;
  ExpectLeftToLibpng(testing::WithPngCrcsFixed(interlaced), DecodeTarget::kColour, "interlaced");

  PngSpec unfiltered = spec;
  unfiltered.filters = {0};
  std::string rows = FilterRows(RandomSamples(3 * 40 * 30, 9), 40, 30, unfiltered);
  rows[121] = 5;  // row 1's filter byte, inside the compressed stream
  const std::string filter5 = testing::PngFromFilteredRows(LayoutOf(40, 30, spec), rows);
  ExpectLeftToLibpng(filter5, DecodeTarget::kColour, "filter type 5");

  ExpectLeftToLibpng(good.substr(0, chunks[2]), DecodeTarget::kColour, "no IEND (truncated)");

  std::string gamma = good;
  std::string gama_chunk;
  AppendPngChunk(gama_chunk, "gAMA", std::string("\x00\x00\xb1\x8f", 4));
  gamma.insert(idat, gama_chunk);
  ExpectLeftToLibpng(gamma, DecodeTarget::kColour, "an ancillary chunk not on the list (gAMA)");

  std::string split = good.substr(0, chunks[2]);
  AppendPngChunk(split, "tEXt", std::string("k\0v", 3));
  AppendPngChunk(split, "IDAT", "");
  AppendPngChunk(split, "IEND", "");
  ExpectLeftToLibpng(split, DecodeTarget::kColour, "IDAT after another chunk");

  ExpectLeftToLibpng(good, DecodeTarget::kDepth16, "colour asked for as depth");
  PngSpec depth_spec;
  depth_spec.bit_depth = 16;
  depth_spec.colour_type = 0;
  const std::string depth = BuildPng(RandomSamples(2 * 8 * 8, 1), 8, 8, depth_spec);
  ExpectLeftToLibpng(depth, DecodeTarget::kColour, "16-bit asked for as colour");
}

}  // namespace
}  // namespace semmap
