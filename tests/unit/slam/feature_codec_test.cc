// Keyframe feature codec: lossless round trip, clear errors for damaged bytes.
#include "core/slam/feature_codec.h"

#include <gtest/gtest.h>

#include <cstdint>
#include <cstring>
#include <string>

namespace semmap {
namespace {

FrameFeatures Sample(int n, int type = CV_8U, int cols = 32) {
  FrameFeatures f;
  cv::RNG rng(7);
  f.descriptors.create(n, cols, type);
  rng.fill(f.descriptors, cv::RNG::UNIFORM, 0, 255);
  for (int i = 0; i < n; ++i) {
    f.keypoints.emplace_back(cv::Point2f(1.5f * i, 480.25f - i), 31.f, 12.5f * i, 0.01f * i, i % 4);
    f.has_depth.push_back(i % 3 != 0);
    f.points_camera.push_back(f.has_depth.back() ? Eigen::Vector3d(0.1 * i, -0.2, 1.0 + 0.01 * i)
                                                 : Eigen::Vector3d::Zero());
  }
  return f;
}

TEST(FeatureCodecTest, RoundTripIsLossless) {
  for (int type : {CV_8U, CV_32F}) {
    const FrameFeatures f = Sample(50, type, type == CV_8U ? 32 : 128);
    StatusOr<FrameFeatures> back = DecodeFeatures(kFeatureCodecFormat, EncodeFeatures(f));
    ASSERT_TRUE(back.ok()) << back.status().ToString();
    ASSERT_EQ(back->size(), f.size());
    EXPECT_EQ(cv::norm(back->descriptors, f.descriptors, cv::NORM_INF), 0);
    for (size_t i = 0; i < f.size(); ++i) {
      EXPECT_EQ(back->keypoints[i].pt, f.keypoints[i].pt);
      EXPECT_EQ(back->keypoints[i].octave, f.keypoints[i].octave);
      EXPECT_EQ(back->keypoints[i].angle, f.keypoints[i].angle);
      EXPECT_EQ(back->has_depth[i], f.has_depth[i]);
      EXPECT_NEAR((back->points_camera[i] - f.points_camera[i]).norm(), 0, 1e-6);
    }
  }
}

TEST(FeatureCodecTest, EmptyFeaturesRoundTrip) {
  StatusOr<FrameFeatures> back = DecodeFeatures(kFeatureCodecFormat, EncodeFeatures({}));
  ASSERT_TRUE(back.ok()) << back.status().ToString();
  EXPECT_EQ(back->size(), 0u);
}

TEST(FeatureCodecTest, DamagedBytesAreDataLoss) {
  const std::string bytes = EncodeFeatures(Sample(20));
  for (size_t cut : {size_t{0}, size_t{3}, size_t{15}, bytes.size() / 2, bytes.size() - 1}) {
    EXPECT_EQ(DecodeFeatures(kFeatureCodecFormat, bytes.substr(0, cut)).status().code(),
              StatusCode::kDataLoss)
        << "cut at " << cut;
  }
  EXPECT_EQ(DecodeFeatures(kFeatureCodecFormat, bytes + "x").status().code(),
            StatusCode::kDataLoss);
  std::string bad_magic = bytes;
  bad_magic[0] = 'X';
  EXPECT_EQ(DecodeFeatures(kFeatureCodecFormat, bad_magic).status().code(), StatusCode::kDataLoss);
}

// magic, count, columns, type: what EncodeFeatures writes first.
std::string Header(uint32_t count, int32_t cols, int32_t type) {
  std::string h = "SMF1";
  h.append(reinterpret_cast<const char*>(&count), 4);
  h.append(reinterpret_cast<const char*>(&cols), 4);
  h.append(reinterpret_cast<const char*>(&type), 4);
  return h;
}

// Found by fuzz_feature_codec (450 runs/s, 250 MB resident): the decoder sized its arrays from
// the header before looking at the data, so a 16-byte header announcing a million keypoints
// allocated ~60 MB, and complete keypoints announcing 4096 float columns ~16 GB of
// descriptors, before "truncated". The size the header announces (checked arithmetic, at its
// largest 16 + 37e6 + 16.4e9 bytes) is now compared with the bytes first.
TEST(FeatureCodecTest, HeaderAnnouncingMoreThanTheBytesIsDataLossBeforeAllocating) {
  const Status huge = DecodeFeatures(kFeatureCodecFormat, Header(1'000'000, 4096, CV_32F)).status();
  EXPECT_EQ(huge.code(), StatusCode::kDataLoss);
  EXPECT_NE(huge.message().find("truncated at keypoint 0"), std::string::npos) << huge.message();
  EXPECT_EQ(DecodeFeatures(kFeatureCodecFormat, Header(1'000'001, 32, CV_8U)).status().code(),
            StatusCode::kDataLoss);

  // Complete keypoints, descriptors announced but absent.
  std::string bytes = EncodeFeatures(Sample(3, CV_8U, 32));
  bytes.resize(16 + 3 * 37);
  std::memcpy(bytes.data() + 8, "\0\x10\0\0", 4);   // 4096 columns
  std::memcpy(bytes.data() + 12, "\x05\0\0\0", 4);  // CV_32F
  const Status descriptors = DecodeFeatures(kFeatureCodecFormat, bytes).status();
  EXPECT_EQ(descriptors.code(), StatusCode::kDataLoss);
  EXPECT_NE(descriptors.message().find("truncated descriptors"), std::string::npos);

  // Keypoints cut in the second one.
  const std::string cut = EncodeFeatures(Sample(3)).substr(0, 16 + 37 + 10);
  EXPECT_NE(DecodeFeatures(kFeatureCodecFormat, cut).status().message().find("keypoint 1"),
            std::string::npos);
}

TEST(FeatureCodecTest, OtherFormatIsInvalidArgument) {
  EXPECT_EQ(DecodeFeatures("jpeg", EncodeFeatures(Sample(3))).status().code(),
            StatusCode::kInvalidArgument);
}

}  // namespace
}  // namespace semmap
