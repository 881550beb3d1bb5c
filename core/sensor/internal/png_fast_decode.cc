// The PNG fast path (png_decoders.h): chunks walked and checked here, the zlib stream inflated
// by libdeflate in one call, the row filters (PNG spec section 9) undone in place, then the
// channels reordered into OpenCV's layout. Any surprise returns nullopt; libpng then decides.
#include <libdeflate.h>
#if defined(__SSE2__)
#include <emmintrin.h>  // part of x86-64; elsewhere the scalar filters do it all
#endif

#include <array>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <exception>
#include <memory>
#include <opencv2/imgproc.hpp>
#include <vector>

#include "common/checked_math.h"
#include "core/sensor/internal/png_decoders.h"

namespace semmap::sensor_internal {
namespace {

constexpr std::string_view kSignature("\x89PNG\r\n\x1a\n", 8);
constexpr uint32_t kMaxChunkLength = 0x7fffffffu;  // the PNG spec's limit

uint32_t BigEndian32(const unsigned char* p) {
  return (uint32_t{p[0]} << 24) | (uint32_t{p[1]} << 16) | (uint32_t{p[2]} << 8) | uint32_t{p[3]};
}

// Chunks that only describe the image (no effect on the pixels libpng hands back with the
// transforms we use) and that libpng accepts in any order: the fast path may skip them.
bool IsInformational(std::string_view type) {
  return type == "tEXt" || type == "zTXt" || type == "iTXt" || type == "tIME" || type == "pHYs";
}

// Scratch bytes reused by each decoding thread: a frame's 1.2 MB of filtered rows would
// otherwise be fresh pages, zeroed and faulted in, on every frame (a third of the decode time).
// Buffers above kKeepBytes (images far larger than a camera's) are released after use.
constexpr size_t kKeepBytes = size_t{32} << 20;
constexpr size_t kPadBytes = 16;  // readable bytes after the last row (LoadPixel reads 4)
class Scratch {
 public:
  uint8_t* Get(size_t bytes) {
    if (bytes > capacity_) {
      data_ = std::make_unique_for_overwrite<uint8_t[]>(bytes + kPadBytes);
      std::memset(data_.get() + bytes, 0, kPadBytes);
      capacity_ = bytes;
    }
    return data_.get();
  }
  void Trim() {
    if (capacity_ > kKeepBytes) {
      data_.reset();
      capacity_ = 0;
    }
  }

 private:
  std::unique_ptr<uint8_t[]> data_;
  size_t capacity_ = 0;
};
thread_local Scratch t_rows;
thread_local Scratch t_joined;

// What IHDR says, for the layouts the fast path takes.
struct Layout {
  uint32_t width = 0;
  uint32_t height = 0;
  int bit_depth = 0;
  int colour_type = 0;         // 0 grey, 2 RGB, 6 RGBA
  size_t bytes_per_pixel = 0;  // also the filters' left-neighbour distance
  size_t row_bytes = 0;        // without the filter byte
};

std::optional<Layout> ReadHeader(const unsigned char* data) {
  Layout layout;
  layout.width = BigEndian32(data);
  layout.height = BigEndian32(data + 4);
  layout.bit_depth = data[8];
  layout.colour_type = data[9];
  const int compression = data[10], filter = data[11], interlace = data[12];
  if (compression != 0 || filter != 0 || interlace != 0) return std::nullopt;
  if (layout.width == 0 || layout.height == 0 || layout.width > kMaxChunkLength ||
      layout.height > kMaxChunkLength) {
    return std::nullopt;
  }
  size_t channels = 0;
  if (layout.colour_type == 0 && (layout.bit_depth == 8 || layout.bit_depth == 16)) {
    channels = 1;
  } else if (layout.colour_type == 2 && layout.bit_depth == 8) {
    channels = 3;
  } else if (layout.colour_type == 6 && layout.bit_depth == 8) {
    channels = 4;
  } else {
    return std::nullopt;
  }
  layout.bytes_per_pixel = channels * static_cast<size_t>(layout.bit_depth / 8);
  const std::optional<uint64_t> row_bytes = CheckedMul(layout.width, layout.bytes_per_pixel);
  if (!row_bytes) return std::nullopt;
  layout.row_bytes = static_cast<size_t>(*row_bytes);
  return layout;
}

// The concatenated IDAT data (a view into `bytes` when there is one IDAT chunk, else copied into
// t_joined), after checking the chunk sequence IHDR, [informational], IDAT..., [informational],
// IEND and every chunk's CRC.
std::optional<std::string_view> ImageData(std::string_view bytes, Layout& layout) {
  if (!bytes.starts_with(kSignature)) return std::nullopt;
  const auto* p = reinterpret_cast<const unsigned char*>(bytes.data());
  size_t offset = kSignature.size();
  std::vector<std::string_view> idat;
  bool have_header = false, idat_done = false;
  while (true) {
    if (bytes.size() - offset < 12) return std::nullopt;  // length, type, CRC
    const uint32_t length = BigEndian32(p + offset);
    if (length > kMaxChunkLength || bytes.size() - offset - 12 < length) return std::nullopt;
    const std::string_view type = bytes.substr(offset + 4, 4);
    const unsigned char* chunk_data = p + offset + 8;
    const uint32_t crc = BigEndian32(chunk_data + length);
    if (libdeflate_crc32(0, p + offset + 4, size_t{length} + 4) != crc) return std::nullopt;
    offset += size_t{length} + 12;
    if (!have_header) {
      if (type != "IHDR" || length != 13) return std::nullopt;
      std::optional<Layout> read = ReadHeader(chunk_data);
      if (!read) return std::nullopt;
      layout = *read;
      have_header = true;
    } else if (type == "IDAT") {
      if (idat_done) return std::nullopt;  // IDAT chunks must be consecutive
      idat.emplace_back(reinterpret_cast<const char*>(chunk_data), length);
    } else if (type == "IEND") {
      if (idat.empty() || length != 0) return std::nullopt;
      break;  // libpng ignores whatever follows IEND too
    } else if (IsInformational(type)) {
      idat_done = !idat.empty();
    } else {
      return std::nullopt;
    }
  }
  if (idat.size() == 1) return idat.front();
  size_t total = 0;
  for (std::string_view chunk : idat) total += chunk.size();
  uint8_t* joined = t_joined.Get(total);
  size_t at = 0;
  for (std::string_view chunk : idat) {
    if (!chunk.empty()) std::memcpy(joined + at, chunk.data(), chunk.size());
    at += chunk.size();
  }
  return std::string_view(reinterpret_cast<const char*>(joined), total);
}

#if !defined(__SSE2__)
// The predictor nearest to a + b - c: left (a), above (b) or above-left (c), in that order on ties.
uint8_t Paeth(int a, int b, int c) {
  const int pa = std::abs(b - c);
  const int pb = std::abs(a - c);
  const int pc = std::abs(a + b - 2 * c);
  if (pa <= pb && pa <= pc) return static_cast<uint8_t>(a);
  return static_cast<uint8_t>(pb <= pc ? b : c);
}
#endif

#if defined(__SSE2__)
// Reads 4 bytes (the buffers have kPadBytes after their last row) and keeps kBpp of them: one
// load, where a kBpp-byte copy would go through the stack and stall store forwarding.
template <size_t kBpp>
__m128i LoadPixel(const uint8_t* p) {
  uint32_t v = 0;
  std::memcpy(&v, p, 4);
  if constexpr (kBpp < 4) v &= (uint32_t{1} << (8 * kBpp)) - 1;
  return _mm_unpacklo_epi8(_mm_cvtsi32_si128(static_cast<int>(v)), _mm_setzero_si128());
}

// Paeth for whole pixels of kBpp (1 to 4) bytes at a time, in 16-bit lanes: the predictor
// nearest to a + b - c, left (a), above (b) or above-left (c) in that order on ties, branch-free.
// The left neighbour is the pixel just written, so pixels go one after another.
template <size_t kBpp>
void PaethRowSse2(uint8_t* row, const uint8_t* prev, size_t n) {
  const __m128i zero = _mm_setzero_si128();
  auto abs16 = [&](__m128i x) { return _mm_max_epi16(x, _mm_sub_epi16(zero, x)); };
  auto select = [](__m128i mask, __m128i yes, __m128i no) {
    return _mm_or_si128(_mm_and_si128(mask, yes), _mm_andnot_si128(mask, no));
  };
  __m128i a = zero, c = zero;  // left of the first pixel: zeros
  for (size_t i = 0; i + kBpp <= n; i += kBpp) {
    const __m128i b = LoadPixel<kBpp>(prev + i);
    const __m128i x = LoadPixel<kBpp>(row + i);
    const __m128i bc = _mm_sub_epi16(b, c), ac = _mm_sub_epi16(a, c);
    const __m128i pa = abs16(bc), pb = abs16(ac), pc = abs16(_mm_add_epi16(bc, ac));
    const __m128i smallest = _mm_min_epi16(pc, _mm_min_epi16(pa, pb));
    __m128i nearest = select(_mm_cmpeq_epi16(pb, smallest), b, c);
    nearest = select(_mm_cmpeq_epi16(pa, smallest), a, nearest);
    a = _mm_and_si128(_mm_add_epi16(x, nearest), _mm_set1_epi16(0xff));
    const auto out = static_cast<uint32_t>(_mm_cvtsi128_si32(_mm_packus_epi16(a, zero)));
    for (size_t k = 0; k < kBpp; ++k) row[i + k] = static_cast<uint8_t>(out >> (8 * k));
    c = b;
  }
}
#endif

// Undoes one row's filter in place; `prev` is the previous row, already unfiltered (zeros
// above the first row). false for a filter type that does not exist.
template <size_t kBpp>
bool UnfilterRow(uint8_t filter, uint8_t* row, const uint8_t* prev, size_t n) {
  switch (filter) {
    case 0:
      return true;
    case 1:  // Sub
      for (size_t i = kBpp; i < n; ++i) row[i] = static_cast<uint8_t>(row[i] + row[i - kBpp]);
      return true;
    case 2:  // Up
      for (size_t i = 0; i < n; ++i) row[i] = static_cast<uint8_t>(row[i] + prev[i]);
      return true;
    case 3:  // Average
      for (size_t i = 0; i < kBpp && i < n; ++i) {
        row[i] = static_cast<uint8_t>(row[i] + (prev[i] >> 1));
      }
      for (size_t i = kBpp; i < n; ++i) {
        row[i] = static_cast<uint8_t>(row[i] + ((row[i - kBpp] + prev[i]) >> 1));
      }
      return true;
    case 4:  // Paeth
#if defined(__SSE2__)
      PaethRowSse2<kBpp>(row, prev, n);
#else
      for (size_t i = 0; i < kBpp && i < n; ++i) row[i] = static_cast<uint8_t>(row[i] + prev[i]);
      for (size_t i = kBpp; i < n; ++i) {
        row[i] = static_cast<uint8_t>(row[i] + Paeth(row[i - kBpp], prev[i], prev[i - kBpp]));
      }
#endif
      return true;
    default:
      return false;
  }
}

template <size_t kBpp>
bool Unfilter(uint8_t* data, const Layout& layout) {
  const size_t stride = layout.row_bytes + 1;
  const std::vector<uint8_t> zeros(layout.row_bytes + kPadBytes, 0);
  const uint8_t* prev = zeros.data();
  for (size_t r = 0; r < layout.height; ++r) {
    uint8_t* row = data + r * stride;
    if (!UnfilterRow<kBpp>(row[0], row + 1, prev, layout.row_bytes)) return false;
    prev = row + 1;
  }
  return true;
}

bool Unfilter(uint8_t* data, const Layout& layout) {
  switch (layout.bytes_per_pixel) {
    case 1:
      return Unfilter<1>(data, layout);
    case 2:
      return Unfilter<2>(data, layout);
    case 3:
      return Unfilter<3>(data, layout);
    case 4:
      return Unfilter<4>(data, layout);
    default:
      return false;
  }
}

// The unfiltered rows (each after its filter byte) in the layout DecodeTarget asks for, as
// libpng's transforms give it: BGR order, alpha dropped, grey expanded for kBgr, 16-bit samples
// in host order.
std::optional<cv::Mat> ToTarget(uint8_t* data, const Layout& layout, DecodeTarget target) {
  const int w = static_cast<int>(layout.width), h = static_cast<int>(layout.height);
  const size_t stride = layout.row_bytes + 1;
  cv::Mat out;
  if (target == DecodeTarget::kDepth16) {
    if (layout.colour_type != 0 || layout.bit_depth != 16) return std::nullopt;
    out.create(h, w, CV_16UC1);
    for (int r = 0; r < h; ++r) {
      const uint8_t* in = data + static_cast<size_t>(r) * stride + 1;
      auto* row = out.ptr<uint16_t>(r);
      for (int c = 0; c < w; ++c) {
        row[c] = static_cast<uint16_t>((in[2 * c] << 8) | in[2 * c + 1]);  // stored big-endian
      }
    }
    return out;
  }
  if (layout.bit_depth != 8) return std::nullopt;  // libpng says why colour must be 8-bit
  static constexpr std::array<int, 7> kTypes = {CV_8UC1, 0, CV_8UC3, 0, 0, 0, CV_8UC4};
  const cv::Mat rows(h, w, kTypes[static_cast<size_t>(layout.colour_type)], data + 1, stride);
  switch (layout.colour_type) {
    case 0:
      if (target == DecodeTarget::kBgr) {
        cv::cvtColor(rows, out, cv::COLOR_GRAY2BGR);
      } else {
        rows.copyTo(out);
      }
      break;
    case 2:
      cv::cvtColor(rows, out, cv::COLOR_RGB2BGR);
      break;
    default:
      cv::cvtColor(rows, out, cv::COLOR_RGBA2BGR);
      break;
  }
  return out;
}

struct DecompressorDeleter {
  void operator()(libdeflate_decompressor* d) const { libdeflate_free_decompressor(d); }
};

}  // namespace

std::optional<cv::Mat> DecodePngFast(std::string_view bytes, const CompressedImageInfo& info,
                                     DecodeTarget target) {
  try {
    Layout layout;
    const std::optional<std::string_view> stream = ImageData(bytes, layout);
    if (!stream || layout.width != info.width || layout.height != info.height) {
      return std::nullopt;
    }
    const std::optional<uint64_t> size = CheckedMul(layout.row_bytes + 1, layout.height);
    if (!size) return std::nullopt;
    const auto filtered_bytes = static_cast<size_t>(*size);
    uint8_t* filtered = t_rows.Get(filtered_bytes);
    const std::unique_ptr<libdeflate_decompressor, DecompressorDeleter> inflater(
        libdeflate_alloc_decompressor());
    if (!inflater) return std::nullopt;
    size_t in_used = 0, out_used = 0;
    // The stream must end exactly where the image data does and hold exactly the image's bytes
    // (libpng only warns about extra data; leave those files to it).
    const libdeflate_result result =
        libdeflate_zlib_decompress_ex(inflater.get(), stream->data(), stream->size(), filtered,
                                      filtered_bytes, &in_used, &out_used);
    std::optional<cv::Mat> out;
    if (result == LIBDEFLATE_SUCCESS && in_used == stream->size() && out_used == filtered_bytes &&
        Unfilter(filtered, layout)) {
      out = ToTarget(filtered, layout, target);
    }
    t_joined.Trim();
    t_rows.Trim();
    return out;
  } catch (const std::exception&) {  // no memory (std::bad_alloc or OpenCV's allocator)
    return std::nullopt;
  }
}

}  // namespace semmap::sensor_internal
