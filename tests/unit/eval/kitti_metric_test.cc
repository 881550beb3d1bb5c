#include "client/eval/kitti_metric.h"

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

#include "tests/testing/temp_dir.h"
#include "tests/testing/units.h"
#include "tests/unit/eval/eval_test_util.h"

namespace semmap {
namespace {

using eval_test::MakePose;
using eval_test::Rot;

// Straight ahead along z (the KITTI camera's forward axis), 1 m per frame, frames 0..n-1.
std::vector<StampedPose> Straight(int n, double metres_per_frame = 1.0) {
  std::vector<StampedPose> out;
  out.reserve(n);
  for (int i = 0; i < n; ++i) out.push_back(MakePose(i, {0, 0, metres_per_frame * i}));
  return out;
}

// Segments of the straight 1 m/frame path of 1001 frames: length L ends at first + L + 1 (the
// first frame whose distance EXCEEDS L), starting frames 0, 10, ... up to 999 - L.
int SegmentsOfLength(int length) { return (999 - length) / 10 + 1; }

TEST(KittiMetricTest, GroundTruthAgainstItselfIsZero) {
  const std::vector<StampedPose> gt = Straight(1001);
  StatusOr<KittiResult> r = ComputeKittiMetric(gt, gt);
  ASSERT_TRUE(r.ok()) << r.status().ToString();
  int expected = 0;
  for (int length = 100; length <= 800; length += 100) expected += SegmentsOfLength(length);
  EXPECT_EQ(r->segments.size(), static_cast<size_t>(expected));  // 440
  EXPECT_EQ(expected, 440);
  EXPECT_EQ(r->t_rel_percent, 0);
  EXPECT_EQ(r->r_rel_deg_per_100m, 0);
  EXPECT_DOUBLE_EQ(r->gt_path_length_m, 1000);
  ASSERT_EQ(r->per_length.size(), 8u);
  EXPECT_EQ(r->per_length[0].segments, 90u);
  EXPECT_EQ(r->per_length[7].segments, 20u);
  EXPECT_EQ(r->segments[0].first_frame, 0);
  EXPECT_EQ(r->segments[0].last_frame, 101);
}

TEST(KittiMetricTest, ConstantScaleDriftGivesItsPercentage) {
  // The estimate travels 1 % too far. A segment of nominal length L spans L + 1 m of ground
  // truth, so its error is 0.01 (L + 1) m and t_err = 0.01 (L + 1) / L, as the devkit divides
  // by the nominal length.
  const std::vector<StampedPose> gt = Straight(1001);
  const std::vector<StampedPose> est = Straight(1001, 1.01);
  StatusOr<KittiResult> r = ComputeKittiMetric(gt, est);
  ASSERT_TRUE(r.ok()) << r.status().ToString();
  double sum = 0;
  int count = 0;
  for (int length = 100; length <= 800; length += 100) {
    sum += SegmentsOfLength(length) * 0.01 * (length + 1) / length;
    count += SegmentsOfLength(length);
  }
  EXPECT_NEAR(r->t_rel_percent, 100 * sum / count, 1e-5);  // single precision, like the devkit
  EXPECT_NEAR(r->t_rel_percent, 1.0, 0.01);
  EXPECT_EQ(r->r_rel_deg_per_100m, 0);
  EXPECT_NEAR(r->per_length[0].t_rel_percent, 1.01, 1e-5);
  EXPECT_NEAR(r->per_length[7].t_rel_percent, 100 * 0.01 * 801 / 800, 1e-5);
}

TEST(KittiMetricTest, ConstantHeadingDriftGivesItsAngleRate) {
  // The estimate's heading turns 0.05 deg per frame about the vertical axis while its positions
  // stay on the ground truth: a segment of L + 1 frames has 0.05 (L + 1) deg of rotational
  // error, r_err = 0.05 (L + 1) / L deg/m. Its translational error is the chord rotated away.
  const std::vector<StampedPose> gt = Straight(1001);
  std::vector<StampedPose> est = gt;
  for (size_t i = 0; i < est.size(); ++i) {
    est[i].T_world_camera.linear() = Rot(0.05 * kDeg * static_cast<double>(i), {0, 1, 0});
  }
  StatusOr<KittiResult> r = ComputeKittiMetric(gt, est);
  ASSERT_TRUE(r.ok()) << r.status().ToString();
  for (const KittiLengthStats& l : r->per_length) {
    EXPECT_NEAR(l.r_rel_deg_per_100m, 100 * 0.05 * (l.length_m + 1) / l.length_m, 2e-4)
        << l.length_m;
  }
  EXPECT_GT(r->t_rel_percent, 0);
}

TEST(KittiMetricTest, SegmentsOnlyStartEveryTenFramesAndNeedTheFullLength) {
  // 0.5 m per frame, 400 frames: 199.5 m. Only 100 m segments fit: the first frame past
  // dist[first] + 100 is first + 201, which must exist: first <= 198, i.e. 0, 10, ..., 190.
  const std::vector<StampedPose> gt = Straight(400, 0.5);
  StatusOr<KittiResult> r = ComputeKittiMetric(gt, gt);
  ASSERT_TRUE(r.ok()) << r.status().ToString();
  EXPECT_EQ(r->segments.size(), 20u);
  ASSERT_EQ(r->per_length.size(), 1u);
  EXPECT_EQ(r->per_length[0].length_m, 100);
  for (const KittiSegment& s : r->segments) {
    EXPECT_EQ(s.first_frame % 10, 0);
    EXPECT_EQ(s.last_frame, s.first_frame + 201);
  }
}

TEST(KittiMetricTest, CustomLengthsForShortSequences) {
  const std::vector<StampedPose> gt = Straight(91);  // 90 m: too short for 100 m segments
  EXPECT_EQ(ComputeKittiMetric(gt, gt).status().code(), StatusCode::kFailedPrecondition);
  KittiOptions options;
  options.lengths_m = {10, 20, 40};
  StatusOr<KittiResult> r = ComputeKittiMetric(gt, Straight(91, 1.02), options);
  ASSERT_TRUE(r.ok()) << r.status().ToString();
  EXPECT_EQ(r->per_length.size(), 3u);
  EXPECT_NEAR(r->per_length[0].t_rel_percent, 2.0 * 11 / 10, 1e-4);
}

TEST(KittiMetricTest, InvalidInputs) {
  const std::vector<StampedPose> gt = Straight(200);
  EXPECT_EQ(ComputeKittiMetric(gt, Straight(199)).status().code(), StatusCode::kInvalidArgument);
  EXPECT_EQ(ComputeKittiMetric({}, {}).status().code(), StatusCode::kInvalidArgument);
  KittiOptions options;
  options.lengths_m = {};
  EXPECT_EQ(ComputeKittiMetric(gt, gt, options).status().code(), StatusCode::kInvalidArgument);
  options.lengths_m = {100, -5};
  EXPECT_EQ(ComputeKittiMetric(gt, gt, options).status().code(), StatusCode::kInvalidArgument);
  options.lengths_m = {100, 100};
  EXPECT_EQ(ComputeKittiMetric(gt, gt, options).status().code(), StatusCode::kInvalidArgument);
  options = KittiOptions();
  options.step_frames = 0;
  EXPECT_EQ(ComputeKittiMetric(gt, gt, options).status().code(), StatusCode::kInvalidArgument);
}

// The shared KITTI ground truth (sequences 00-10).
class KittiRealTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = testing::SharedDataDir();
    if (dir_.empty()) GTEST_SKIP() << "SEMMAP_SHARED_DATA_DIR (../shared/data) not found";
  }
  std::string dir_;
};

TEST_F(KittiRealTest, EverySequenceAgainstItselfIsZero) {
  for (const char* seq : {"00", "01", "02", "03", "04", "05", "06", "07", "08", "09", "10"}) {
    StatusOr<std::vector<StampedPose>> gt = ReadKittiPoses(dir_ + "/kitti_poses/" + seq + ".txt");
    ASSERT_TRUE(gt.ok()) << gt.status().ToString();
    StatusOr<KittiResult> r = ComputeKittiMetric(*gt, *gt);
    ASSERT_TRUE(r.ok()) << seq << ": " << r.status().ToString();
    EXPECT_GT(r->segments.size(), 0u) << seq;
    EXPECT_LT(r->t_rel_percent, 1e-6) << seq;
    EXPECT_LT(r->r_rel_deg_per_100m, 1e-6) << seq;
  }
}

TEST_F(KittiRealTest, ScaleDriftOnSequence07GivesOnePercentOfTheChords) {
  // Scaling every position by 1.01 (about the start) leaves the rotations and makes each
  // segment's error 1 % of its chord |t_last - t_first| (E = (I, -0.01 R_first^T chord)).
  StatusOr<std::vector<StampedPose>> gt = ReadKittiPoses(dir_ + "/kitti_poses/07.txt");
  ASSERT_TRUE(gt.ok()) << gt.status().ToString();
  std::vector<StampedPose> est = *gt;
  for (StampedPose& p : est) p.T_world_camera.translation() *= 1.01;
  StatusOr<KittiResult> r = ComputeKittiMetric(*gt, est);
  ASSERT_TRUE(r.ok()) << r.status().ToString();
  double sum = 0;
  for (const KittiSegment& s : r->segments) {
    const double chord = ((*gt)[s.last_frame].T_world_camera.translation() -
                          (*gt)[s.first_frame].T_world_camera.translation())
                             .norm();
    EXPECT_NEAR(s.t_err, 0.01 * chord / s.length_m, 1e-7);
    EXPECT_NEAR(s.r_err, 0, 1e-6);
    sum += 0.01 * chord / s.length_m;
  }
  EXPECT_NEAR(r->t_rel_percent, 100 * sum / static_cast<double>(r->segments.size()), 1e-4);
  // Sequence 07 winds through streets: chords are shorter than the segment lengths.
  EXPECT_GT(r->t_rel_percent, 0.5);
  EXPECT_LT(r->t_rel_percent, 1.02);
}

}  // namespace
}  // namespace semmap
