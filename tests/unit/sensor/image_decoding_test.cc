#include "core/sensor/image_decoding.h"

#include <gtest/gtest.h>

#include <opencv2/imgproc.hpp>
#include <tuple>

#include "tests/testing/synthetic_frames.h"

namespace semmap {
namespace {

ImageMessage Raw(const cv::Mat& m, const std::string& encoding) {
  ImageMessage msg;
  msg.kind = ImageMessage::Kind::kRaw;
  msg.encoding = encoding;
  msg.width = m.cols;
  msg.height = m.rows;
  msg.step = static_cast<uint32_t>(m.step[0]);
  msg.data.assign(reinterpret_cast<const char*>(m.data), m.total() * m.elemSize());
  return msg;
}

ImageMessage Compressed(const std::string& format, std::string bytes) {
  ImageMessage msg;
  msg.kind = ImageMessage::Kind::kCompressed;
  msg.encoding = format;
  msg.data = std::move(bytes);
  return msg;
}

TEST(ImageDecodingTest, RawColourEncodings) {
  const cv::Mat bgr = testing::TexturedImage(64, 48, 1);
  auto decoded = DecodeColour(Raw(bgr, "bgr8"), 64, 48);
  ASSERT_TRUE(decoded.ok()) << decoded.status().ToString();
  EXPECT_EQ(cv::norm(*decoded, bgr, cv::NORM_INF), 0);
  cv::Mat rgb;
  cv::cvtColor(bgr, rgb, cv::COLOR_BGR2RGB);
  decoded = DecodeColour(Raw(rgb, "rgb8"), 64, 48);
  ASSERT_TRUE(decoded.ok());
  EXPECT_EQ(cv::norm(*decoded, bgr, cv::NORM_INF), 0);  // converted back to BGR
}

TEST(ImageDecodingTest, PngRoundTripAndErrors) {
  const cv::Mat bgr = testing::TexturedImage(64, 48, 2);
  auto decoded = DecodeColour(Compressed("png", testing::EncodePng(bgr)), 64, 48);
  ASSERT_TRUE(decoded.ok());
  EXPECT_EQ(cv::norm(*decoded, bgr, cv::NORM_INF), 0);

  EXPECT_EQ(DecodeColour(Compressed("png", testing::EncodePng(bgr)), 640, 480).status().code(),
            StatusCode::kInvalidArgument);
  EXPECT_EQ(DecodeColour(Compressed("png", "garbage"), 64, 48).status().code(),
            StatusCode::kInvalidArgument);
  EXPECT_EQ(DecodeColour(Compressed("tiff", "x"), 64, 48).status().code(),
            StatusCode::kInvalidArgument);
  ImageMessage bad_step = Raw(bgr, "bgr8");
  bad_step.step = 10;
  EXPECT_EQ(DecodeColour(bad_step, 64, 48).status().code(), StatusCode::kInvalidArgument);
  ImageMessage short_data = Raw(bgr, "bgr8");
  short_data.data.resize(100);
  EXPECT_EQ(DecodeColour(short_data, 64, 48).status().code(), StatusCode::kInvalidArgument);
  EXPECT_EQ(DecodeColour(Raw(bgr, "yuv"), 64, 48).status().code(), StatusCode::kInvalidArgument);
}

TEST(ImageDecodingTest, DepthFormats) {
  const cv::Mat depth = testing::PlaneDepth(64, 48);
  DepthMessage raw{Raw(depth, "16UC1"), 5000};
  auto decoded = DecodeDepth(raw, 64, 48);
  ASSERT_TRUE(decoded.ok());
  EXPECT_EQ(decoded->depth_scale, 5000);
  EXPECT_EQ(cv::norm(decoded->raw, depth, cv::NORM_INF), 0);

  DepthMessage png{Compressed("png", testing::EncodePng(depth)), 5000};
  decoded = DecodeDepth(png, 64, 48);
  ASSERT_TRUE(decoded.ok());
  EXPECT_EQ(cv::norm(decoded->raw, depth, cv::NORM_INF), 0);

  cv::Mat metres;
  depth.convertTo(metres, CV_32FC1, 1.0 / 5000);
  metres.at<float>(0, 0) = std::nanf("");
  DepthMessage floats{Raw(metres, "32FC1"), 0};
  decoded = DecodeDepth(floats, 64, 48);
  ASSERT_TRUE(decoded.ok()) << decoded.status().ToString();
  EXPECT_EQ(decoded->raw.at<uint16_t>(0, 0), 0);  // NaN → no depth
  EXPECT_NEAR(decoded->raw.at<uint16_t>(10, 10), depth.at<uint16_t>(10, 10), 1);

  DepthMessage no_scale{Raw(depth, "16UC1"), 0};
  EXPECT_EQ(DecodeDepth(no_scale, 64, 48).status().code(), StatusCode::kInvalidArgument);
  DepthMessage colour_png{Compressed("png", testing::EncodePng(testing::TexturedImage(64, 48, 0))),
                          5000};
  EXPECT_EQ(DecodeDepth(colour_png, 64, 48).status().code(), StatusCode::kInvalidArgument);
}

// The hostile-client finding: width x height x bytes per pixel wrapped around 2^64 and passed
// the size check with 0 bytes of data. Sizes are checked against the camera first, and computed
// in checked arithmetic where they are not.
TEST(ImageDecodingTest, OverflowingRawSizesAreInvalidArgument) {
  const uint32_t huge = 1u << 31;
  for (const char* encoding : {"32FC1", "16UC1"}) {
    ImageMessage image;
    image.kind = ImageMessage::Kind::kRaw;
    image.encoding = encoding;
    image.width = huge;
    image.height = huge;
    const StatusOr<DecodedDepth> depth = DecodeDepth({image, 5000}, 640, 480);
    ASSERT_FALSE(depth.ok());
    EXPECT_EQ(depth.status().code(), StatusCode::kInvalidArgument);
    EXPECT_NE(depth.status().message().find("is 2147483648x2147483648 but the session camera is "
                                            "640x480"),
              std::string::npos)
        << depth.status().message();
  }
  for (const char* encoding : {"rgb8", "bgr8", "mono8"}) {
    ImageMessage image;
    image.kind = ImageMessage::Kind::kRaw;
    image.encoding = encoding;
    image.width = 0xFFFFFFFFu;
    image.height = 0xFFFFFFFFu;
    image.step = 0xFFFFFFFFu;
    EXPECT_EQ(DecodeColour(image, 640, 480).status().code(), StatusCode::kInvalidArgument);
  }
  // A camera of the claimed size (INT_MAX wide): the data size check is exact, no wrap-around.
  ImageMessage wide;
  wide.kind = ImageMessage::Kind::kRaw;
  wide.encoding = "rgb8";
  wide.width = 0x7FFFFFFFu;
  wide.height = 1;
  wide.step = 0xFFFFFFFFu;
  const StatusOr<cv::Mat> refused = DecodeColour(wide, 0x7FFFFFFF, 1);
  ASSERT_FALSE(refused.ok());
  EXPECT_NE(refused.status().message().find("is less than width*bytes_per_pixel"),
            std::string::npos)
      << refused.status().message();
  wide.step = 0;
  EXPECT_NE(DecodeColour(wide, 0x7FFFFFFF, 1).status().message().find("needs 6442450941"),
            std::string::npos);
}

// Found by fuzz_image_decode: a client step that is no whole number of samples (13 bytes for
// 16UC1) made OpenCV throw from the cv::Mat constructor, which ended the server.
TEST(ImageDecodingTest, StepsThatSplitASampleAreInvalidArgument) {
  for (const auto& [encoding, type, bytes] :
       {std::tuple{"16UC1", CV_16UC1, 2}, std::tuple{"32FC1", CV_32FC1, 4}}) {
    const cv::Mat depth(4, 3, type, cv::Scalar(1));
    ImageMessage image = Raw(depth, encoding);
    image.step = static_cast<uint32_t>(3 * bytes + 1);
    image.data.assign(image.step * 4, '\0');
    const StatusOr<DecodedDepth> decoded = DecodeDepth({image, 5000}, 3, 4);
    ASSERT_FALSE(decoded.ok()) << encoding;
    EXPECT_EQ(decoded.status().code(), StatusCode::kInvalidArgument);
    EXPECT_NE(decoded.status().message().find("is not a multiple of its"), std::string::npos)
        << decoded.status().message();
    // A padded step of whole samples is fine.
    image.step = static_cast<uint32_t>(4 * bytes);
    image.data.assign(image.step * 4, '\0');
    EXPECT_TRUE(DecodeDepth({image, 5000}, 3, 4).ok()) << encoding;
  }
}

}  // namespace
}  // namespace semmap
