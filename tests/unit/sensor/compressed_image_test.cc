// PNG / JPEG decoding of outside bytes: every colour model the server takes, headers read before
// any pixel, and truncated or damaged files refused instead of half-decoded.
#include "core/sensor/compressed_image.h"

#include <gtest/gtest.h>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <string>
#include <vector>

#include "core/sensor/image_decoding.h"
#include "tests/testing/hostile_images.h"
#include "tests/testing/synthetic_frames.h"

namespace semmap {
namespace {

std::string Encode(const cv::Mat& image, const std::string& ext,
                   const std::vector<int>& params = {}) {
  std::vector<uchar> buf;
  EXPECT_TRUE(cv::imencode(ext, image, buf, params));
  return std::string(buf.begin(), buf.end());
}

StatusOr<cv::Mat> Decode(const std::string& bytes, DecodeTarget target) {
  SEMMAP_ASSIGN_OR_RETURN(CompressedImageInfo info, ProbeCompressedImage(bytes));
  return DecodeCompressedImage(bytes, info, target);
}

void ExpectInvalid(const StatusOr<cv::Mat>& decoded, const std::string& fragment) {
  ASSERT_FALSE(decoded.ok());
  EXPECT_EQ(decoded.status().code(), StatusCode::kInvalidArgument) << decoded.status().ToString();
  EXPECT_NE(decoded.status().message().find(fragment), std::string::npos)
      << decoded.status().message();
}

TEST(CompressedImageTest, PngColourModelsDecodeLikeOpenCv) {
  const cv::Mat bgr = testing::TexturedImage(64, 48, 4);
  cv::Mat grey, bgra;
  cv::cvtColor(bgr, grey, cv::COLOR_BGR2GRAY);
  cv::cvtColor(bgr, bgra, cv::COLOR_BGR2BGRA);
  StatusOr<cv::Mat> colour = Decode(Encode(bgr, ".png"), DecodeTarget::kColour);
  ASSERT_TRUE(colour.ok()) << colour.status().ToString();
  EXPECT_EQ(cv::norm(*colour, bgr, cv::NORM_INF), 0);
  StatusOr<cv::Mat> from_grey = Decode(Encode(grey, ".png"), DecodeTarget::kColour);
  ASSERT_TRUE(from_grey.ok());
  EXPECT_EQ(from_grey->type(), CV_8UC1);
  EXPECT_EQ(cv::norm(*from_grey, grey, cv::NORM_INF), 0);
  StatusOr<cv::Mat> grey_as_bgr = Decode(Encode(grey, ".png"), DecodeTarget::kBgr);
  ASSERT_TRUE(grey_as_bgr.ok());
  EXPECT_EQ(grey_as_bgr->type(), CV_8UC3);
  StatusOr<cv::Mat> from_bgra = Decode(Encode(bgra, ".png"), DecodeTarget::kColour);
  ASSERT_TRUE(from_bgra.ok());
  EXPECT_EQ(cv::norm(*from_bgra, bgr, cv::NORM_INF), 0);  // alpha dropped
  // Interlaced (Adam7) and maximum compression take the same path.
  StatusOr<cv::Mat> packed =
      Decode(Encode(bgr, ".png", {cv::IMWRITE_PNG_COMPRESSION, 9}), DecodeTarget::kBgr);
  ASSERT_TRUE(packed.ok());
  EXPECT_EQ(cv::norm(*packed, bgr, cv::NORM_INF), 0);
}

TEST(CompressedImageTest, DepthPngIsSixteenBitGreyOnly) {
  const cv::Mat depth = testing::PlaneDepth(64, 48);
  StatusOr<cv::Mat> decoded = Decode(Encode(depth, ".png"), DecodeTarget::kDepth16);
  ASSERT_TRUE(decoded.ok()) << decoded.status().ToString();
  EXPECT_EQ(decoded->type(), CV_16UC1);
  EXPECT_EQ(cv::norm(*decoded, depth, cv::NORM_INF), 0);  // byte order handled
  ExpectInvalid(Decode(Encode(testing::TexturedImage(64, 48, 0), ".png"), DecodeTarget::kDepth16),
                "single-channel 16-bit");
  ExpectInvalid(Decode(Encode(depth, ".png"), DecodeTarget::kColour), "8-bit channels");
  ExpectInvalid(Decode(Encode(testing::TexturedImage(64, 48, 0), ".jpg"), DecodeTarget::kDepth16),
                "16-bit png");
}

TEST(CompressedImageTest, JpegDecodesToBgrOrGrey) {
  const cv::Mat bgr = testing::TexturedImage(64, 48, 5);
  const std::string jpeg = Encode(bgr, ".jpg", {cv::IMWRITE_JPEG_QUALITY, 95});
  StatusOr<cv::Mat> decoded = Decode(jpeg, DecodeTarget::kColour);
  ASSERT_TRUE(decoded.ok()) << decoded.status().ToString();
  const cv::Mat reference =
      cv::imdecode(std::vector<uchar>(jpeg.begin(), jpeg.end()), cv::IMREAD_COLOR);
  EXPECT_LE(cv::norm(*decoded, reference, cv::NORM_INF), 2);  // same libjpeg, same pixels
  cv::Mat grey;
  cv::cvtColor(bgr, grey, cv::COLOR_BGR2GRAY);
  StatusOr<cv::Mat> from_grey = Decode(Encode(grey, ".jpg"), DecodeTarget::kColour);
  ASSERT_TRUE(from_grey.ok());
  EXPECT_EQ(from_grey->type(), CV_8UC1);
  // Progressive JPEG.
  StatusOr<cv::Mat> progressive =
      Decode(Encode(bgr, ".jpg", {cv::IMWRITE_JPEG_PROGRESSIVE, 1}), DecodeTarget::kBgr);
  ASSERT_TRUE(progressive.ok()) << progressive.status().ToString();
  EXPECT_EQ(progressive->size(), bgr.size());
}

// The hostile-client finding: the first half of a PNG decoded to an image whose lower rows were
// invented. Every cut point of either format is an error now.
TEST(CompressedImageTest, EveryTruncationIsRefused) {
  const cv::Mat bgr = testing::TexturedImage(160, 120, 6);
  const cv::Mat depth = testing::PlaneDepth(160, 120);
  const struct {
    std::string bytes;
    DecodeTarget target;
  } cases[] = {{Encode(bgr, ".png"), DecodeTarget::kColour},
               {Encode(depth, ".png"), DecodeTarget::kDepth16},
               {Encode(bgr, ".jpg"), DecodeTarget::kColour},
               {Encode(bgr, ".jpg", {cv::IMWRITE_JPEG_PROGRESSIVE, 1}), DecodeTarget::kColour}};
  for (const auto& c : cases) {
    ASSERT_TRUE(Decode(c.bytes, c.target).ok());
    for (double fraction : {0.05, 0.25, 0.5, 0.75, 0.9, 0.99}) {
      const StatusOr<cv::Mat> cut = Decode(testing::Truncated(c.bytes, fraction), c.target);
      EXPECT_FALSE(cut.ok()) << fraction;
      if (!cut.ok()) {
        EXPECT_EQ(cut.status().code(), StatusCode::kInvalidArgument);
      }
    }
    // Short by one byte: the PNG's IEND CRC, the JPEG's EOI marker.
    EXPECT_FALSE(Decode(c.bytes.substr(0, c.bytes.size() - 1), c.target).ok());
  }
}

TEST(CompressedImageTest, DamagedDataIsRefused) {
  std::string png = Encode(testing::TexturedImage(64, 48, 7), ".png");
  // Flip a byte inside the first IDAT: its CRC no longer matches.
  const size_t idat = png.find("IDAT");
  ASSERT_NE(idat, std::string::npos);
  png[idat + 20] = static_cast<char>(png[idat + 20] ^ 0x55);
  ExpectInvalid(Decode(png, DecodeTarget::kColour), "damaged");
  ExpectInvalid(Decode("not an image at all", DecodeTarget::kColour), "neither a PNG nor a JPEG");
  ExpectInvalid(Decode(std::string("\x89PNG\r\n\x1a\n", 8), DecodeTarget::kColour),
                "not a readable PNG");
  ExpectInvalid(Decode(std::string("\xff\xd8\xff\xe0", 4), DecodeTarget::kColour),
                "not a readable JPEG");
}

// A 400 kB file claiming 400 MB of pixels: its header says so before anything is allocated.
TEST(CompressedImageTest, HeaderIsReadBeforeAnyPixel) {
  const std::string bomb = testing::PngBomb(20000, 20000);
  EXPECT_LT(bomb.size(), 1u << 20);
  StatusOr<CompressedImageInfo> info = ProbeCompressedImage(bomb);
  ASSERT_TRUE(info.ok()) << info.status().ToString();
  EXPECT_EQ(info->width, 20000u);
  EXPECT_EQ(info->height, 20000u);
  EXPECT_EQ(info->channels, 1);
  ImageMessage colour;
  colour.kind = ImageMessage::Kind::kCompressed;
  colour.encoding = "png";
  colour.data = bomb;
  const StatusOr<cv::Mat> refused = DecodeColour(colour, 640, 480);
  ExpectInvalid(refused, "is 20000x20000 but the session camera is 640x480");
  // A small bomb is a real image: it does decode.
  StatusOr<cv::Mat> small = Decode(testing::PngBomb(300, 200), DecodeTarget::kColour);
  ASSERT_TRUE(small.ok()) << small.status().ToString();
  EXPECT_EQ(small->size(), cv::Size(300, 200));
  EXPECT_EQ(cv::countNonZero(*small), 0);
}

TEST(CompressedImageTest, DeclaredFormatMustMatchTheBytes) {
  ImageMessage colour;
  colour.kind = ImageMessage::Kind::kCompressed;
  colour.encoding = "png";
  colour.data = Encode(testing::TexturedImage(64, 48, 1), ".jpg");
  ExpectInvalid(DecodeColour(colour, 64, 48), "declared png but its bytes are a jpeg");
}

}  // namespace
}  // namespace semmap
