#include "core/sensor/compressed_image.h"

// clang-format off
#include <cstdio>  // jpeglib.h needs FILE and size_t first
#include <jpeglib.h>
// clang-format on
#include <png.h>

#include <csetjmp>
#include <cstring>
#include <exception>
#include <optional>
#include <vector>

#include "common/checked_math.h"
#include "core/sensor/internal/png_decoders.h"

// libpng and libjpeg report errors by longjmp. Every function below that calls setjmp holds only
// trivially destructible locals and does no C++ allocation between setjmp and the library calls,
// so a jump never skips a destructor; pixels are allocated by the caller between the phases.

namespace semmap {
namespace {

constexpr size_t kMessageBytes = 200;
// Progressive JPEGs may hold any number of scans, each a full pass over the coefficients: a small
// file with thousands of scans costs minutes of CPU. Real encoders write about 10.
constexpr int kMaxJpegScans = 256;

// The decoded image and a pointer to each of its rows, for the decoders to write into.
struct Pixels {
  cv::Mat image;
  std::vector<unsigned char*> rows;
};
StatusOr<Pixels> AllocatePixels(const CompressedImageInfo& info, int cv_type) {
  Pixels out;
  try {
    out.image.create(static_cast<int>(info.height), static_cast<int>(info.width), cv_type);
    out.rows.resize(info.height);
  } catch (const std::exception&) {  // std::bad_alloc, or cv::Exception from the allocator
    return ResourceExhaustedError("out of memory for a decoded " + std::to_string(info.width) +
                                  "x" + std::to_string(info.height) + " image");
  }
  for (uint32_t r = 0; r < info.height; ++r) out.rows[r] = out.image.ptr(static_cast<int>(r));
  return out;
}

// ---- PNG ----

struct PngInput {
  const unsigned char* data = nullptr;
  size_t size = 0;
  size_t offset = 0;
};

struct PngReader {
  png_structp png = nullptr;
  png_infop info = nullptr;
  PngInput input;
  char message[kMessageBytes] = {};

  PngReader() = default;
  PngReader(const PngReader&) = delete;
  PngReader& operator=(const PngReader&) = delete;
  ~PngReader() {
    if (png != nullptr) png_destroy_read_struct(&png, info != nullptr ? &info : nullptr, nullptr);
  }
};

void PngFail(png_structp png, png_const_charp message) {
  auto* reader = static_cast<PngReader*>(png_get_error_ptr(png));
  std::snprintf(reader->message, kMessageBytes, "%s", message);
  png_longjmp(png, 1);
}

// Ancillary-chunk trouble (e.g. an odd colour profile); a damaged image is always an error.
void PngWarn(png_structp, png_const_charp) {}

void PngRead(png_structp png, png_bytep out, size_t length) {
  auto* reader = static_cast<PngReader*>(png_get_io_ptr(png));
  PngInput& in = reader->input;
  if (length > in.size - in.offset) {
    PngFail(png, "the data ends before the image does (truncated)");
    return;
  }
  std::memcpy(out, in.data + in.offset, length);
  in.offset += length;
}

bool PngCreate(PngReader& reader, std::string_view bytes) {
  reader.input = {reinterpret_cast<const unsigned char*>(bytes.data()), bytes.size(), 0};
  reader.png = png_create_read_struct(PNG_LIBPNG_VER_STRING, &reader, PngFail, PngWarn);
  if (reader.png == nullptr) return false;
  reader.info = png_create_info_struct(reader.png);
  if (reader.info == nullptr) return false;
  png_set_read_fn(reader.png, &reader, PngRead);
  return true;
}

// Reads up to the first image data; false with reader.message on any error.
bool PngReadInfo(PngReader& reader) {
  if (setjmp(png_jmpbuf(reader.png))) return false;
  png_read_info(reader.png, reader.info);
  return true;
}

// Applies the transforms (already set), then reads every row and the end of the stream.
bool PngReadRows(PngReader& reader, png_bytep* rows, size_t expected_row_bytes) {
  if (setjmp(png_jmpbuf(reader.png))) return false;
  png_read_update_info(reader.png, reader.info);
  if (png_get_rowbytes(reader.png, reader.info) != expected_row_bytes) {
    PngFail(reader.png, "unexpected row size after conversion");
  }
  png_read_image(reader.png, rows);
  png_read_end(reader.png, nullptr);
  return true;
}

StatusOr<CompressedImageInfo> ProbePng(std::string_view bytes) {
  PngReader reader;
  if (!PngCreate(reader, bytes)) return ResourceExhaustedError("cannot start the PNG decoder");
  if (!PngReadInfo(reader)) {
    return InvalidArgumentError(std::string("is not a readable PNG: ") + reader.message);
  }
  CompressedImageInfo info;
  info.format = CompressedFormat::kPng;
  info.width = png_get_image_width(reader.png, reader.info);
  info.height = png_get_image_height(reader.png, reader.info);
  const int bit_depth = png_get_bit_depth(reader.png, reader.info);
  info.bit_depth = bit_depth == 16 ? 16 : 8;
  switch (png_get_color_type(reader.png, reader.info)) {
    case PNG_COLOR_TYPE_GRAY:
      info.channels = 1;
      break;
    case PNG_COLOR_TYPE_GRAY_ALPHA:
      info.channels = 2;
      break;
    case PNG_COLOR_TYPE_PALETTE:
      info.channels = png_get_valid(reader.png, reader.info, PNG_INFO_tRNS) ? 4 : 3;
      break;
    case PNG_COLOR_TYPE_RGB:
      info.channels = 3;
      break;
    default:
      info.channels = 4;
      break;
  }
  return info;
}

}  // namespace

StatusOr<cv::Mat> sensor_internal::DecodePngWithLibpng(std::string_view bytes,
                                                       const CompressedImageInfo& info,
                                                       DecodeTarget target) {
  PngReader reader;
  if (!PngCreate(reader, bytes)) return ResourceExhaustedError("cannot start the PNG decoder");
  if (!PngReadInfo(reader)) {
    return InvalidArgumentError(std::string("is not a readable PNG: ") + reader.message);
  }
  png_structp png = reader.png;
  png_infop pinfo = reader.info;
  if (png_get_image_width(png, pinfo) != info.width ||
      png_get_image_height(png, pinfo) != info.height) {
    return InvalidArgumentError("PNG header changed between reads");
  }
  const int colour_type = png_get_color_type(png, pinfo);
  const int bit_depth = png_get_bit_depth(png, pinfo);
  int cv_type = CV_8UC3;
  size_t bytes_per_pixel = 3;
  if (target == DecodeTarget::kDepth16) {
    if (colour_type != PNG_COLOR_TYPE_GRAY || bit_depth != 16) {
      return InvalidArgumentError("depth png must be single-channel 16-bit (it has " +
                                  std::to_string(info.channels) + " channel(s) of " +
                                  std::to_string(bit_depth) + " bits)");
    }
    png_set_swap(png);  // PNG stores 16-bit samples big-endian
    cv_type = CV_16UC1;
    bytes_per_pixel = 2;
  } else {
    if (bit_depth == 16) return InvalidArgumentError("colour image must have 8-bit channels");
    if (colour_type == PNG_COLOR_TYPE_PALETTE) png_set_palette_to_rgb(png);
    if (colour_type == PNG_COLOR_TYPE_GRAY && bit_depth < 8) {
      png_set_expand_gray_1_2_4_to_8(png);
    }
    if (colour_type & PNG_COLOR_MASK_ALPHA) png_set_strip_alpha(png);
    const bool grey = !(colour_type & PNG_COLOR_MASK_COLOR);
    if (grey && target == DecodeTarget::kBgr) png_set_gray_to_rgb(png);
    if (grey && target == DecodeTarget::kColour) {
      cv_type = CV_8UC1;
      bytes_per_pixel = 1;
    } else {
      png_set_bgr(png);
    }
  }
  png_set_interlace_handling(png);
  SEMMAP_ASSIGN_OR_RETURN(Pixels pixels, AllocatePixels(info, cv_type));
  if (!PngReadRows(reader, pixels.rows.data(), static_cast<size_t>(info.width) * bytes_per_pixel)) {
    return InvalidArgumentError(std::string("PNG data is damaged: ") + reader.message);
  }
  return std::move(pixels.image);
}

namespace {

// ---- JPEG ----

struct JpegReader {
  jpeg_decompress_struct cinfo{};
  jpeg_error_mgr error{};
  jpeg_progress_mgr progress{};
  std::jmp_buf jump{};
  char message[JMSG_LENGTH_MAX] = {};
  bool created = false;

  JpegReader() = default;
  JpegReader(const JpegReader&) = delete;
  JpegReader& operator=(const JpegReader&) = delete;
  ~JpegReader() {
    if (created) jpeg_destroy_decompress(&cinfo);
  }
};

JpegReader* ReaderOf(j_common_ptr cinfo) { return static_cast<JpegReader*>(cinfo->client_data); }

[[noreturn]] void JpegFail(j_common_ptr cinfo) {
  JpegReader* reader = ReaderOf(cinfo);
  (*cinfo->err->format_message)(cinfo, reader->message);
  std::longjmp(reader->jump, 1);
}

// Level -1 is a corrupt-data warning (premature end, bad Huffman code, extraneous bytes):
// libjpeg would fill in grey and go on; we refuse the image. Trace messages are ignored.
void JpegMessage(j_common_ptr cinfo, int level) {
  if (level < 0) JpegFail(cinfo);
}

void JpegProgress(j_common_ptr cinfo) {
  auto* d = reinterpret_cast<j_decompress_ptr>(cinfo);
  if (d->input_scan_number > kMaxJpegScans) {
    JpegReader* reader = ReaderOf(cinfo);
    std::snprintf(reader->message, sizeof(reader->message), "more than %d progressive scans",
                  kMaxJpegScans);
    std::longjmp(reader->jump, 1);
  }
}

// Creates the decoder on `bytes` and reads the header; false with reader.message on an error.
bool JpegReadHeader(JpegReader& reader, std::string_view bytes) {
  reader.cinfo.err = jpeg_std_error(&reader.error);
  reader.error.error_exit = JpegFail;
  reader.error.emit_message = JpegMessage;
  reader.cinfo.client_data = &reader;
  if (setjmp(reader.jump)) return false;
  jpeg_create_decompress(&reader.cinfo);
  reader.created = true;
  reader.progress.progress_monitor = JpegProgress;
  reader.cinfo.progress = &reader.progress;
  jpeg_mem_src(&reader.cinfo, reinterpret_cast<const unsigned char*>(bytes.data()),
               static_cast<unsigned long>(bytes.size()));
  jpeg_read_header(&reader.cinfo, TRUE);
  return true;
}

bool JpegReadRows(JpegReader& reader, JSAMPROW* rows, JDIMENSION height, JDIMENSION width) {
  if (setjmp(reader.jump)) return false;
  jpeg_start_decompress(&reader.cinfo);
  if (reader.cinfo.output_width != width || reader.cinfo.output_height != height) {
    std::snprintf(reader.message, sizeof(reader.message), "output size differs from the header");
    return false;
  }
  while (reader.cinfo.output_scanline < height) {
    jpeg_read_scanlines(&reader.cinfo, rows + reader.cinfo.output_scanline,
                        height - reader.cinfo.output_scanline);
  }
  jpeg_finish_decompress(&reader.cinfo);
  return true;
}

StatusOr<CompressedImageInfo> ProbeJpeg(std::string_view bytes) {
  JpegReader reader;
  if (!JpegReadHeader(reader, bytes)) {
    return InvalidArgumentError(std::string("is not a readable JPEG: ") + reader.message);
  }
  CompressedImageInfo info;
  info.format = CompressedFormat::kJpeg;
  info.width = reader.cinfo.image_width;
  info.height = reader.cinfo.image_height;
  info.channels = reader.cinfo.num_components;
  info.bit_depth = reader.cinfo.data_precision;
  return info;
}

StatusOr<cv::Mat> DecodeJpeg(std::string_view bytes, const CompressedImageInfo& info,
                             DecodeTarget target) {
  if (target == DecodeTarget::kDepth16) {
    return InvalidArgumentError("depth must be a 16-bit png, not a JPEG");
  }
  JpegReader reader;
  if (!JpegReadHeader(reader, bytes)) {
    return InvalidArgumentError(std::string("is not a readable JPEG: ") + reader.message);
  }
  jpeg_decompress_struct& cinfo = reader.cinfo;
  if (cinfo.image_width != info.width || cinfo.image_height != info.height) {
    return InvalidArgumentError("JPEG header changed between reads");
  }
  if (cinfo.data_precision != 8)
    return InvalidArgumentError("colour image must have 8-bit channels");
  if (cinfo.jpeg_color_space == JCS_CMYK || cinfo.jpeg_color_space == JCS_YCCK) {
    return InvalidArgumentError("CMYK JPEGs are not supported (use RGB or greyscale)");
  }
  const bool grey = cinfo.jpeg_color_space == JCS_GRAYSCALE;
  int cv_type = CV_8UC3;
  if (grey && target == DecodeTarget::kColour) {
    cinfo.out_color_space = JCS_GRAYSCALE;
    cv_type = CV_8UC1;
  } else {
    cinfo.out_color_space = JCS_EXT_BGR;
  }
  SEMMAP_ASSIGN_OR_RETURN(Pixels pixels, AllocatePixels(info, cv_type));
  if (!JpegReadRows(reader, pixels.rows.data(), info.height, info.width)) {
    return InvalidArgumentError(std::string("JPEG data is damaged: ") + reader.message);
  }
  return std::move(pixels.image);
}

bool StartsWith(std::string_view bytes, std::string_view prefix) {
  return bytes.size() >= prefix.size() && bytes.substr(0, prefix.size()) == prefix;
}

}  // namespace

std::string_view CompressedFormatName(CompressedFormat format) {
  return format == CompressedFormat::kPng ? "png" : "jpeg";
}

StatusOr<CompressedImageInfo> ProbeCompressedImage(std::string_view bytes) {
  StatusOr<CompressedImageInfo> info = InvalidArgumentError("");
  if (StartsWith(bytes, "\x89PNG\r\n\x1a\n")) {
    info = ProbePng(bytes);
  } else if (StartsWith(bytes, "\xff\xd8\xff")) {
    info = ProbeJpeg(bytes);
  } else {
    return InvalidArgumentError("is neither a PNG nor a JPEG (" + std::to_string(bytes.size()) +
                                " bytes with no PNG or JPEG signature)");
  }
  if (!info.ok()) return info;
  // Both formats allow up to 2^31 - 1 (PNG) or 65535 (JPEG) per side; OpenCV sizes are int.
  if (info->width == 0 || info->height == 0 || !CheckedNarrow<int>(info->width) ||
      !CheckedNarrow<int>(info->height)) {
    return InvalidArgumentError("has an invalid size " + std::to_string(info->width) + "x" +
                                std::to_string(info->height));
  }
  return info;
}

StatusOr<cv::Mat> DecodeCompressedImage(std::string_view bytes, const CompressedImageInfo& info,
                                        DecodeTarget target) {
  if (info.format == CompressedFormat::kPng) {
    std::optional<cv::Mat> fast = sensor_internal::DecodePngFast(bytes, info, target);
    if (fast) return std::move(*fast);
    return sensor_internal::DecodePngWithLibpng(bytes, info, target);
  }
  return DecodeJpeg(bytes, info, target);
}

}  // namespace semmap
