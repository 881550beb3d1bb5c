// ATE and RPE on the real TUM fr3/teddy ground truth, against numbers produced by the TUM RGB-D
// benchmark's scripts (evaluate_ate.py; the similarity variant evaluate_ate_scale.py;
// evaluate_rpe.py --fixed_delta --max_pairs 0) on the same files, printed with full precision.
// data/teddy_est_*.txt: the ground truth sampled at the 200 colour stamps (30 Hz), rigidly moved
// (35 deg, 2.4 m) or moved and scaled by 0.8, with 1 cm Gaussian noise, 6 decimals; one stamp
// (1341841877.280100) sits exactly between two ground-truth stamps (see association_test.cc).
#include <gtest/gtest.h>

#include <string>

#include "client/eval/ate.h"
#include "client/eval/rpe.h"
#include "tests/testing/temp_dir.h"

namespace semmap {
namespace {

// Far tighter than the 1e-6 m we promise: the differences are floating-point round-off.
constexpr double kTolerance = 1e-9;

class TeddyTest : public ::testing::Test {
 protected:
  void SetUp() override {
    const std::string dir = testing::SharedDataDir();
    if (dir.empty()) GTEST_SKIP() << "SEMMAP_SHARED_DATA_DIR (../shared/data) not found";
    StatusOr<std::vector<StampedPose>> gt =
        ReadTumTrajectory(dir + "/tum_fr3_teddy_200/groundtruth.txt");
    ASSERT_TRUE(gt.ok()) << gt.status().ToString();
    gt_ = *gt;
    const std::string data = std::string(SEMMAP_SOURCE_DIR) + "/tests/unit/eval/data/";
    StatusOr<std::vector<StampedPose>> rigid = ReadTumTrajectory(data + "teddy_est_rigid.txt");
    StatusOr<std::vector<StampedPose>> sim = ReadTumTrajectory(data + "teddy_est_sim.txt");
    ASSERT_TRUE(rigid.ok()) << rigid.status().ToString();
    ASSERT_TRUE(sim.ok()) << sim.status().ToString();
    rigid_ = *rigid;
    sim_ = *sim;
  }

  std::vector<StampedPose> gt_, rigid_, sim_;
};

void ExpectStats(const ErrorStatistics& s, double rmse, double mean, double median, double std,
                 double min, double max, double tolerance = kTolerance) {
  EXPECT_NEAR(s.rmse, rmse, tolerance);
  EXPECT_NEAR(s.mean, mean, tolerance);
  EXPECT_NEAR(s.median, median, tolerance);
  EXPECT_NEAR(s.std, std, tolerance);
  EXPECT_NEAR(s.min, min, tolerance);
  EXPECT_NEAR(s.max, max, tolerance);
}

TEST_F(TeddyTest, GroundTruthAgainstItselfIsZero) {
  StatusOr<AteResult> ate = ComputeAte(gt_, gt_);
  ASSERT_TRUE(ate.ok()) << ate.status().ToString();
  EXPECT_EQ(ate->pairs.size(), gt_.size());
  EXPECT_LT(ate->stats.max, 1e-12);
  StatusOr<RpeResult> rpe = ComputeRpe(gt_, gt_);
  ASSERT_TRUE(rpe.ok()) << rpe.status().ToString();
  EXPECT_LT(rpe->translation_m.max, 1e-12);
  EXPECT_LT(rpe->rotation_deg.max, 1e-4);
}

TEST_F(TeddyTest, AteRigidMatchesEvaluateAte) {
  StatusOr<AteResult> ate = ComputeAte(gt_, rigid_);
  ASSERT_TRUE(ate.ok()) << ate.status().ToString();
  EXPECT_EQ(ate->pairs.size(), 196u);
  ExpectStats(ate->stats, 0.01690699185541637, 0.015706228685664975, 0.01519812032472398,
              0.00625785538924559, 0.0031844614494904184, 0.034589570274030694);
  // The planted midpoint stamp pairs with the later ground-truth stamp, as in the script.
  bool found = false;
  for (const AtePair& p : ate->pairs) {
    if (p.est_stamp_ns == 1'341'841'877'280'100'000) {
      EXPECT_EQ(p.gt_stamp_ns, 1'341'841'877'285'100'000);
      found = true;
    }
  }
  EXPECT_TRUE(found);
}

TEST_F(TeddyTest, AteOfAScaledEstimateMatchesTheScripts) {
  StatusOr<AteResult> rigid = ComputeAte(gt_, sim_);
  ASSERT_TRUE(rigid.ok()) << rigid.status().ToString();
  EXPECT_EQ(rigid->pairs.size(), 196u);
  ExpectStats(rigid->stats, 0.11164639714426557, 0.10083850583869532, 0.0923259188554644,
              0.0479219546295274, 0.030494016258428774, 0.21551158374426657);

  AteOptions options;
  options.estimate_scale = true;
  StatusOr<AteResult> sim = ComputeAte(gt_, sim_, options);
  ASSERT_TRUE(sim.ok()) << sim.status().ToString();
  EXPECT_NEAR(sim->alignment.scale, 1.245856568201217, 1e-12);
  ExpectStats(sim->stats, 0.020802890996322747, 0.019091462870279848, 0.018160254921552092,
              0.008262948582534683, 0.002757812045126536, 0.05114768948561119);
}

TEST_F(TeddyTest, RpeMatchesEvaluateRpe) {
  StatusOr<RpeResult> rpe = ComputeRpe(gt_, rigid_);  // --delta 1 --delta_unit s
  ASSERT_TRUE(rpe.ok()) << rpe.status().ToString();
  EXPECT_EQ(rpe->pairs.size(), 165u);
  ExpectStats(rpe->translation_m, 0.024048431544406664, 0.022325079587281343, 0.021594755456623836,
              0.0089396801490639, 0.00386893149444019, 0.05411022794608661);
  // Rotational errors here are ~1e-4 deg, where arccos of the trace resolves ~1e-7 deg.
  ExpectStats(rpe->rotation_deg, 7.795823720977598e-05, 7.330284389554892e-05,
              7.095059341519043e-05, 2.6536386824141764e-05, 1.628896300592164e-05,
              0.00014169041820065868, 1e-6);

  RpeOptions frames;
  frames.delta = 10;
  frames.unit = RpeDeltaUnit::kFrames;
  rpe = ComputeRpe(gt_, rigid_, frames);
  ASSERT_TRUE(rpe.ok()) << rpe.status().ToString();
  EXPECT_EQ(rpe->pairs.size(), 185u);
  ExpectStats(rpe->translation_m, 0.023890469679189102, 0.02219081215920252, 0.021625994194018432,
              0.008849994192497726, 0.004959298257796397, 0.04372448057172236);
}

}  // namespace
}  // namespace semmap
