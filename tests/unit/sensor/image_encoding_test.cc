#include "core/sensor/image_encoding.h"

#include <gtest/gtest.h>

#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <vector>

#include "core/sensor/compressed_image.h"

namespace semmap {
namespace {

// A smooth gradient with some structure: JPEG keeps it within a few grey levels.
cv::Mat EncodingGradient(int type) {
  cv::Mat image(48, 64, type);
  for (int y = 0; y < image.rows; ++y) {
    for (int x = 0; x < image.cols; ++x) {
      for (int c = 0; c < image.channels(); ++c) {
        const int value = (x * 3 + y * 2 + c * 40) % 256;
        if (image.depth() == CV_16U) {
          image.ptr<uint16_t>(y)[x] = static_cast<uint16_t>(value * 250 + 7);
        } else {
          image.ptr<uint8_t>(y)[x * image.channels() + c] = static_cast<uint8_t>(value);
        }
      }
    }
  }
  return image;
}

cv::Mat DecodeEncoded(const std::string& bytes, DecodeTarget target) {
  StatusOr<CompressedImageInfo> info = ProbeCompressedImage(bytes);
  EXPECT_TRUE(info.ok()) << info.status().ToString();
  if (!info.ok()) return {};
  StatusOr<cv::Mat> decoded = DecodeCompressedImage(bytes, *info, target);
  EXPECT_TRUE(decoded.ok()) << decoded.status().ToString();
  return decoded.ok() ? *decoded : cv::Mat();
}

double MaxPixelDifference(const cv::Mat& a, const cv::Mat& b) {
  if (a.size() != b.size() || a.type() != b.type()) return 1e9;
  double max = 0;
  cv::Mat difference;
  cv::absdiff(a.reshape(1), b.reshape(1), difference);
  cv::minMaxLoc(difference, nullptr, &max);
  return max;
}

TEST(ImageEncodingTest, PngIsLosslessForGreyColourAndSixteenBit) {
  for (int level : {0, 3, 9}) {
    const cv::Mat grey = EncodingGradient(CV_8UC1);
    const cv::Mat bgr = EncodingGradient(CV_8UC3);
    const cv::Mat depth = EncodingGradient(CV_16UC1);
    auto grey_png = EncodePng(grey, level);
    auto bgr_png = EncodePng(bgr, level);
    auto depth_png = EncodePng(depth, level);
    ASSERT_TRUE(grey_png.ok() && bgr_png.ok() && depth_png.ok());
    EXPECT_EQ(MaxPixelDifference(DecodeEncoded(*grey_png, DecodeTarget::kColour), grey), 0);
    EXPECT_EQ(MaxPixelDifference(DecodeEncoded(*bgr_png, DecodeTarget::kColour), bgr),
              0);  // order kept
    EXPECT_EQ(MaxPixelDifference(DecodeEncoded(*depth_png, DecodeTarget::kDepth16), depth), 0);
  }
}

TEST(ImageEncodingTest, PngWithAlphaKeepsItsColours) {
  const cv::Mat bgra = EncodingGradient(CV_8UC4);
  auto png = EncodePng(bgra);
  ASSERT_TRUE(png.ok());
  cv::Mat bgr;
  cv::cvtColor(bgra, bgr, cv::COLOR_BGRA2BGR);
  EXPECT_EQ(MaxPixelDifference(DecodeEncoded(*png, DecodeTarget::kColour), bgr), 0);
  // What another decoder makes of it: OpenCV reads the same pixels and the alpha channel.
  const cv::Mat read =
      cv::imdecode(std::vector<uchar>(png->begin(), png->end()), cv::IMREAD_UNCHANGED);
  EXPECT_EQ(MaxPixelDifference(read, bgra), 0);
}

// As close as OpenCV's own encoder at the same quality (the gradient wraps around, so both lose
// a few grey levels at its edges), and in the right channel order.
TEST(ImageEncodingTest, JpegIsAsCloseAsOpenCvsForColourAndGrey) {
  const auto mean_error = [](const cv::Mat& decoded, const cv::Mat& image) {
    cv::Mat difference;
    cv::absdiff(decoded.reshape(1), image.reshape(1), difference);
    return cv::mean(difference)[0];
  };
  for (int type : {CV_8UC3, CV_8UC1}) {
    const cv::Mat image = EncodingGradient(type);
    auto jpeg = EncodeJpeg(image, 95);
    ASSERT_TRUE(jpeg.ok()) << jpeg.status().ToString();
    const cv::Mat decoded = DecodeEncoded(*jpeg, DecodeTarget::kColour);
    ASSERT_EQ(decoded.type(), image.type());
    std::vector<uchar> reference;
    ASSERT_TRUE(cv::imencode(".jpg", image, reference, {cv::IMWRITE_JPEG_QUALITY, 95}));
    const cv::Mat opencv = cv::imdecode(reference, cv::IMREAD_UNCHANGED);
    EXPECT_LT(mean_error(decoded, image), mean_error(opencv, image) + 1.0) << "type " << type;
    EXPECT_LT(mean_error(decoded, image), 6.0) << "type " << type;
  }
}

TEST(ImageEncodingTest, OtherImagesAreInvalidArgument) {
  EXPECT_EQ(EncodePng(cv::Mat()).status().code(), StatusCode::kInvalidArgument);
  EXPECT_EQ(EncodePng(cv::Mat(4, 4, CV_32FC1, 1.0f)).status().code(), StatusCode::kInvalidArgument);
  EXPECT_EQ(EncodeJpeg(cv::Mat(4, 4, CV_16UC1)).status().code(), StatusCode::kInvalidArgument);
  EXPECT_EQ(EncodeJpeg(cv::Mat()).status().code(), StatusCode::kInvalidArgument);
}

}  // namespace
}  // namespace semmap
