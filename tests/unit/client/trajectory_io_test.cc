#include "client/datasets/trajectory_io.h"

#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <string>

#include "tests/testing/temp_dir.h"
#include "tests/unit/client/dataset_test_util.h"

namespace semmap {
namespace {

using testing::TempDir;
using testing::WriteFile;

Eigen::Isometry3d MakePose(double angle, const Eigen::Vector3d& axis, const Eigen::Vector3d& t) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = Eigen::AngleAxisd(angle, axis.normalized()).toRotationMatrix();
  T.translation() = t;
  return T;
}

TEST(TumTrajectoryTest, ReadsCommentsBlankLinesAndCommas) {
  TempDir tmp;
  WriteFile(tmp.File("gt.txt"),
            "# ground truth\n"
            "\n"
            "1341841873.4151 -2.1837 0.6821 1.4854 -0.2651 0.7889 -0.5183 0.1970\n"
            "1341841873.425100,1,2,3,0,0,0,1   # trailing comment\n"
            "  1341841873.435, 4, 5, 6, 0, 0, 1, 0\r\n");
  StatusOr<std::vector<StampedPose>> poses = ReadTumTrajectory(tmp.File("gt.txt"));
  ASSERT_TRUE(poses.ok()) << poses.status().ToString();
  ASSERT_EQ(poses->size(), 3u);
  EXPECT_EQ((*poses)[0].stamp_ns, 1341841873415100000LL);
  EXPECT_EQ((*poses)[1].stamp_ns, 1341841873425100000LL);
  EXPECT_EQ((*poses)[2].stamp_ns, 1341841873435000000LL);
  EXPECT_TRUE(
      (*poses)[0].T_world_camera.translation().isApprox(Eigen::Vector3d(-2.1837, 0.6821, 1.4854)));
  const Eigen::Quaterniond q0(0.1970, -0.2651, 0.7889, -0.5183);
  EXPECT_TRUE((*poses)[0].T_world_camera.linear().isApprox(q0.normalized().toRotationMatrix()));
  EXPECT_TRUE((*poses)[1].T_world_camera.linear().isIdentity());
  // qz = 1: 180 degrees about z.
  EXPECT_TRUE((*poses)[2].T_world_camera.linear().isApprox(
      Eigen::Vector3d(-1, -1, 1).asDiagonal().toDenseMatrix()));
}

TEST(TumTrajectoryTest, EmptyFileGivesNoPoses) {
  TempDir tmp;
  WriteFile(tmp.File("gt.txt"), "# nothing yet\n");
  StatusOr<std::vector<StampedPose>> poses = ReadTumTrajectory(tmp.File("gt.txt"));
  ASSERT_TRUE(poses.ok());
  EXPECT_TRUE(poses->empty());
}

TEST(TumTrajectoryTest, MalformedLinesNameFileAndLine) {
  TempDir tmp;
  const std::string good = "1.0 0 0 0 0 0 0 1\n";
  for (const std::string bad : {
           "2.0 0 0 0 0 0 1\n",                     // 7 fields
           "2.0 0 0 0 0 0 0 1 9\n",                 // 9 fields
           "x 0 0 0 0 0 0 1\n",                     // bad stamp
           "2.0 0 abc 0 0 0 0 1\n",                 // bad number
           "2.0 0 nan 0 0 0 0 1\n",                 // non-finite
           "2.0 0 0 0 0 0 0 0\n",                   // zero quaternion
           "2.0 0 0 0 0.5 0 0 0.5\n",               // not unit length
           "99999999999999999999 0 0 0 0 0 0 1\n",  // stamp beyond int64 nanoseconds
       }) {
    WriteFile(tmp.File("gt.txt"), std::string(good).append("# comment\n").append(bad));
    StatusOr<std::vector<StampedPose>> poses = ReadTumTrajectory(tmp.File("gt.txt"));
    ASSERT_FALSE(poses.ok()) << bad;
    EXPECT_EQ(poses.status().code(), StatusCode::kInvalidArgument);
    EXPECT_NE(poses.status().message().find("gt.txt:3:"), std::string::npos)
        << bad << " -> " << poses.status().message();
  }
}

TEST(TumTrajectoryTest, MissingFileIsNotFound) {
  TempDir tmp;
  EXPECT_EQ(ReadTumTrajectory(tmp.File("none.txt")).status().code(), StatusCode::kNotFound);
}

TEST(TumTrajectoryTest, WriteReadRoundTripIsExactToTheMicrosecond) {
  TempDir tmp;
  std::vector<StampedPose> written;
  for (int i = 0; i < 50; ++i) {
    StampedPose p;
    p.stamp_ns = 1341841873273798000LL + i * 33'367'000LL;  // whole microseconds
    p.T_world_camera = MakePose(0.1 * i - 2.0, Eigen::Vector3d(1, 2 - 0.1 * i, 0.5),
                                Eigen::Vector3d(0.01 * i, -3.5, 1e3 + i));
    written.push_back(p);
  }
  ASSERT_TRUE(WriteTumTrajectory(tmp.File("traj.txt"), written).ok());
  StatusOr<std::vector<StampedPose>> read = ReadTumTrajectory(tmp.File("traj.txt"));
  ASSERT_TRUE(read.ok()) << read.status().ToString();
  ASSERT_EQ(read->size(), written.size());
  for (size_t i = 0; i < written.size(); ++i) {
    EXPECT_EQ((*read)[i].stamp_ns, written[i].stamp_ns);
    EXPECT_NEAR(
        ((*read)[i].T_world_camera.translation() - written[i].T_world_camera.translation()).norm(),
        0, 1e-8);
    // 9 decimals per quaternion component: rotation matrices agree to ~1e-9.
    EXPECT_LT(((*read)[i].T_world_camera.linear() - written[i].T_world_camera.linear())
                  .cwiseAbs()
                  .maxCoeff(),
              5e-9);
  }
}

TEST(TumTrajectoryTest, WriteHasHeaderAndRoundsStampsToMicroseconds) {
  TempDir tmp;
  StampedPose p;
  p.stamp_ns = 1'500'000'499LL;
  ASSERT_TRUE(WriteTumTrajectory(tmp.File("traj.txt"), {p}).ok());
  std::ifstream in(tmp.File("traj.txt"));
  std::string header, line;
  std::getline(in, header);
  std::getline(in, line);
  EXPECT_EQ(header.rfind("# timestamp tx ty tz qx qy qz qw", 0), 0u) << header;
  EXPECT_EQ(line,
            "1.500000 0.000000000 0.000000000 0.000000000 0.000000000 0.000000000 "
            "0.000000000 1.000000000");
}

TEST(TumTrajectoryTest, WriteRejectsNonFinitePosesAndBadPaths) {
  TempDir tmp;
  StampedPose p;
  p.T_world_camera.translation().x() = std::nan("");
  EXPECT_EQ(WriteTumTrajectory(tmp.File("traj.txt"), {p}).code(), StatusCode::kInvalidArgument);
  EXPECT_FALSE(WriteTumTrajectory(tmp.File("no/such/dir/traj.txt"), {}).ok());
}

TEST(KittiPosesTest, ReadsRowMajor3x4) {
  TempDir tmp;
  WriteFile(tmp.File("poses.txt"),
            "1.000000e+00 0 0 1.5 0 1 0 -2.5e-01 0 0 1 3\n"
            "0 -1 0 4 1 0 0 5 0 0 1 6\n");
  StatusOr<std::vector<StampedPose>> poses = ReadKittiPoses(tmp.File("poses.txt"));
  ASSERT_TRUE(poses.ok()) << poses.status().ToString();
  ASSERT_EQ(poses->size(), 2u);
  EXPECT_EQ((*poses)[0].stamp_ns, 0);
  EXPECT_EQ((*poses)[1].stamp_ns, 1);
  EXPECT_TRUE((*poses)[0].T_world_camera.translation().isApprox(Eigen::Vector3d(1.5, -0.25, 3)));
  Eigen::Matrix3d R;
  R << 0, -1, 0, 1, 0, 0, 0, 0, 1;
  EXPECT_TRUE((*poses)[1].T_world_camera.linear().isApprox(R));
  EXPECT_TRUE((*poses)[1].T_world_camera.translation().isApprox(Eigen::Vector3d(4, 5, 6)));
}

TEST(KittiPosesTest, StampsFromCaller) {
  TempDir tmp;
  WriteFile(tmp.File("poses.txt"), "1 0 0 0 0 1 0 0 0 0 1 0\n1 0 0 1 0 1 0 0 0 0 1 0\n");
  StatusOr<std::vector<StampedPose>> poses = ReadKittiPoses(tmp.File("poses.txt"), {100, 200});
  ASSERT_TRUE(poses.ok()) << poses.status().ToString();
  EXPECT_EQ((*poses)[0].stamp_ns, 100);
  EXPECT_EQ((*poses)[1].stamp_ns, 200);
  StatusOr<std::vector<StampedPose>> mismatch = ReadKittiPoses(tmp.File("poses.txt"), {1, 2, 3});
  ASSERT_FALSE(mismatch.ok());
  EXPECT_NE(mismatch.status().message().find("2 poses but 3 timestamps"), std::string::npos)
      << mismatch.status().message();
}

TEST(KittiPosesTest, RejectsBadLines) {
  TempDir tmp;
  for (const std::string bad : {"1 0 0 0 0 1 0 0 0 0 1\n", "1 0 0 0 0 1 0 0 0 0 1 zz\n",
                                "2 0 0 0 0 1 0 0 0 0 1 0\n", "-1 0 0 0 0 1 0 0 0 0 1 0\n"}) {
    WriteFile(tmp.File("poses.txt"), "1 0 0 0 0 1 0 0 0 0 1 0\n" + bad);
    StatusOr<std::vector<StampedPose>> poses = ReadKittiPoses(tmp.File("poses.txt"));
    ASSERT_FALSE(poses.ok()) << bad;
    EXPECT_NE(poses.status().message().find("poses.txt:2:"), std::string::npos)
        << poses.status().message();
  }
}

TEST(KittiPosesTest, WriteReadRoundTrip) {
  TempDir tmp;
  std::vector<StampedPose> written;
  written.reserve(10);
  for (int i = 0; i < 10; ++i) {
    written.push_back({i, MakePose(0.3 * i, Eigen::Vector3d(0.2, 1, 0.1 * i),
                                   Eigen::Vector3d(i * 1.1, -0.5 * i, 100.0 + i))});
  }
  ASSERT_TRUE(WriteKittiPoses(tmp.File("poses.txt"), written).ok());
  StatusOr<std::vector<StampedPose>> read = ReadKittiPoses(tmp.File("poses.txt"));
  ASSERT_TRUE(read.ok()) << read.status().ToString();
  ASSERT_EQ(read->size(), written.size());
  for (size_t i = 0; i < written.size(); ++i) {
    EXPECT_TRUE(
        (*read)[i].T_world_camera.matrix().isApprox(written[i].T_world_camera.matrix(), 1e-8));
  }
}

}  // namespace
}  // namespace semmap
