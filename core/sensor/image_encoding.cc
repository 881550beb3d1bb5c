#include "core/sensor/image_encoding.h"

// clang-format off
#include <cstdio>  // jpeglib.h needs FILE and size_t first
#include <jpeglib.h>
// clang-format on
#include <png.h>

#include <algorithm>
#include <csetjmp>
#include <cstdlib>
#include <vector>

// As in compressed_image.cc: the libraries report errors by longjmp, so the functions that call
// setjmp hold only trivially destructible locals between setjmp and the library calls; the
// output string and the row pointers are owned by the caller and outlive the jump.

namespace semmap {
namespace {

struct PngWriter {
  png_structp png = nullptr;
  png_infop info = nullptr;
  std::string* out = nullptr;
  PngWriter() = default;
  PngWriter(const PngWriter&) = delete;
  PngWriter& operator=(const PngWriter&) = delete;
  ~PngWriter() {
    if (png != nullptr) png_destroy_write_struct(&png, info != nullptr ? &info : nullptr);
  }
};

void PngWriteFail(png_structp png, png_const_charp) { png_longjmp(png, 1); }
void PngWriteWarn(png_structp, png_const_charp) {}
void PngWriteData(png_structp png, png_bytep data, size_t length) {
  auto* writer = static_cast<PngWriter*>(png_get_io_ptr(png));
  writer->out->append(reinterpret_cast<const char*>(data), length);
}
void PngFlush(png_structp) {}

bool PngWriteAll(PngWriter& writer, png_uint_32 width, png_uint_32 height, int bit_depth,
                 int colour_type, int compression_level, bool swap_bytes, bool bgr,
                 png_bytep* rows) {
  if (setjmp(png_jmpbuf(writer.png))) return false;
  png_set_write_fn(writer.png, &writer, PngWriteData, PngFlush);
  png_set_IHDR(writer.png, writer.info, width, height, bit_depth, colour_type, PNG_INTERLACE_NONE,
               PNG_COMPRESSION_TYPE_DEFAULT, PNG_FILTER_TYPE_DEFAULT);
  png_set_compression_level(writer.png, compression_level);
  png_write_info(writer.png, writer.info);
  if (swap_bytes) png_set_swap(writer.png);  // PNG stores 16-bit samples big-endian
  if (bgr) png_set_bgr(writer.png);
  png_write_image(writer.png, rows);
  png_write_end(writer.png, nullptr);
  return true;
}

struct JpegWriter {
  jpeg_compress_struct cinfo{};
  jpeg_error_mgr error{};
  std::jmp_buf jump{};
  unsigned char* buffer = nullptr;
  unsigned long size = 0;  // NOLINT(google-runtime-int): libjpeg's type
  bool created = false;
  JpegWriter() = default;
  JpegWriter(const JpegWriter&) = delete;
  JpegWriter& operator=(const JpegWriter&) = delete;
  ~JpegWriter() {
    if (created) jpeg_destroy_compress(&cinfo);
    std::free(buffer);  // NOLINT(cppcoreguidelines-no-malloc): jpeg_mem_dest's realloc'd buffer
  }
};

void JpegWriteFail(j_common_ptr cinfo) {
  auto* writer = static_cast<JpegWriter*>(cinfo->client_data);
  std::longjmp(writer->jump, 1);
}

bool JpegWriteAll(JpegWriter& writer, const cv::Mat& image, int quality,
                  std::vector<JSAMPROW>& rows) {
  if (setjmp(writer.jump)) return false;
  jpeg_create_compress(&writer.cinfo);
  writer.created = true;
  jpeg_mem_dest(&writer.cinfo, &writer.buffer, &writer.size);
  writer.cinfo.image_width = static_cast<JDIMENSION>(image.cols);
  writer.cinfo.image_height = static_cast<JDIMENSION>(image.rows);
  writer.cinfo.input_components = image.channels();
  writer.cinfo.in_color_space = image.channels() == 1 ? JCS_GRAYSCALE : JCS_EXT_BGR;
  jpeg_set_defaults(&writer.cinfo);
  jpeg_set_quality(&writer.cinfo, quality, TRUE);
  jpeg_start_compress(&writer.cinfo, TRUE);
  while (writer.cinfo.next_scanline < writer.cinfo.image_height) {
    jpeg_write_scanlines(&writer.cinfo, &rows[writer.cinfo.next_scanline],
                         writer.cinfo.image_height - writer.cinfo.next_scanline);
  }
  jpeg_finish_compress(&writer.cinfo);
  return true;
}

template <typename Row>
std::vector<Row> RowPointers(const cv::Mat& image) {
  std::vector<Row> rows(static_cast<size_t>(image.rows));
  for (int y = 0; y < image.rows; ++y) rows[static_cast<size_t>(y)] = const_cast<Row>(image.ptr(y));
  return rows;
}

}  // namespace

StatusOr<std::string> EncodePng(const cv::Mat& image, int compression_level) {
  if (image.empty()) return InvalidArgumentError("PNG encoding: the image is empty");
  int colour_type = 0;
  int bit_depth = 8;
  switch (image.type()) {
    case CV_8UC1:
      colour_type = PNG_COLOR_TYPE_GRAY;
      break;
    case CV_8UC3:
      colour_type = PNG_COLOR_TYPE_RGB;
      break;
    case CV_8UC4:
      colour_type = PNG_COLOR_TYPE_RGB_ALPHA;
      break;
    case CV_16UC1:
      colour_type = PNG_COLOR_TYPE_GRAY;
      bit_depth = 16;
      break;
    default:
      return InvalidArgumentError(
          "PNG encoding takes 8-bit grey, BGR or BGRA, or 16-bit grey "
          "images");
  }
  std::string out;
  std::vector<png_bytep> rows = RowPointers<png_bytep>(image);
  PngWriter writer;
  writer.out = &out;
  writer.png = png_create_write_struct(PNG_LIBPNG_VER_STRING, &writer, PngWriteFail, PngWriteWarn);
  if (writer.png != nullptr) writer.info = png_create_info_struct(writer.png);
  if (writer.info == nullptr) return ResourceExhaustedError("cannot start the PNG encoder");
  const bool little_endian_samples = bit_depth == 16;  // x86 and ARM hosts
  if (!PngWriteAll(writer, static_cast<png_uint_32>(image.cols),
                   static_cast<png_uint_32>(image.rows), bit_depth, colour_type,
                   std::clamp(compression_level, 0, 9), little_endian_samples,
                   image.channels() >= 3, rows.data())) {
    return InternalError("PNG encoding failed");
  }
  return out;
}

StatusOr<std::string> EncodeJpeg(const cv::Mat& image, int quality) {
  if (image.empty()) return InvalidArgumentError("JPEG encoding: the image is empty");
  if (image.type() != CV_8UC1 && image.type() != CV_8UC3) {
    return InvalidArgumentError("JPEG encoding takes 8-bit grey or BGR images");
  }
  std::vector<JSAMPROW> rows = RowPointers<JSAMPROW>(image);
  JpegWriter writer;
  writer.cinfo.err = jpeg_std_error(&writer.error);
  writer.error.error_exit = JpegWriteFail;
  writer.cinfo.client_data = &writer;
  if (!JpegWriteAll(writer, image, std::clamp(quality, 1, 100), rows)) {
    return InternalError("JPEG encoding failed");
  }
  return std::string(reinterpret_cast<const char*>(writer.buffer), writer.size);
}

}  // namespace semmap
