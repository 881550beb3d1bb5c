// EstimateObjectPosition on exact points: the plane centre where a plane fits, the centre ray
// at the points' median distance where it does not, the median without a ray.
#include "core/recognition/object_position.h"

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <vector>

namespace semmap {
namespace {

// A 0.3 x 0.2 m face at 1.5 m, tilted 30 degrees about the camera's y axis, centred on the
// optical axis; `rows` x `cols` points on its top-left quarter only (texture clustered off
// centre), so a median would be off the face's centre.
std::vector<Eigen::Vector3d> QuarterFace(int rows, int cols, Eigen::Vector3d* centre) {
  const Eigen::Vector3d c(0.0, 0.0, 1.5);
  const Eigen::Vector3d u =
      Eigen::AngleAxisd(0.5236, Eigen::Vector3d::UnitY()) * Eigen::Vector3d::UnitX();
  const Eigen::Vector3d v = Eigen::Vector3d::UnitY();
  std::vector<Eigen::Vector3d> out;
  for (int i = 0; i < rows; ++i) {
    for (int j = 0; j < cols; ++j) {
      const double a = cols > 1 ? -0.15 + 0.15 * j / (cols - 1) : -0.075;
      const double b = rows > 1 ? -0.1 + 0.1 * i / (rows - 1) : -0.05;
      out.emplace_back(c + a * u + b * v);
    }
  }
  *centre = c;
  return out;
}

TEST(ObjectPositionTest, PlaneCentreEvenWhenFeaturesClusterOnOneSide) {
  Eigen::Vector3d centre;
  std::vector<Eigen::Vector3d> points = QuarterFace(5, 6, &centre);
  // Three background points 40 cm behind (an edge's depth from the wall).
  for (int i = 0; i < 3; ++i) points.emplace_back(points[static_cast<size_t>(i)] * (1.9 / 1.5));
  const ObjectPosition p =
      EstimateObjectPosition(points, Eigen::Vector3d::UnitZ(), ObjectRecognitionOptions());
  EXPECT_EQ(p.source, PositionSource::kPlane);
  EXPECT_LT((p.p - centre).norm(), 1e-6);
  // The extent is of the points on the plane (a quarter face, 0.1 m tall: with 5 rows of
  // points the 10-90% range is the full span), not of the background points.
  EXPECT_NEAR(p.extent.y(), 0.1, 1e-9);
  EXPECT_LT(p.extent.z(), 0.1);

  const ObjectPosition median =
      EstimateObjectPosition(points, std::nullopt, ObjectRecognitionOptions());
  EXPECT_EQ(median.source, PositionSource::kMedian);
  EXPECT_GT((median.p - centre).norm(), 0.05);  // what the plane centre buys
}

TEST(ObjectPositionTest, NearlyCollinearPointsFallBackToTheRay) {
  Eigen::Vector3d centre;
  const std::vector<Eigen::Vector3d> strip = QuarterFace(1, 12, &centre);  // one row
  const Eigen::Vector3d ray(0.02, -0.01, 1.0);
  const ObjectPosition p = EstimateObjectPosition(strip, ray, ObjectRecognitionOptions());
  EXPECT_EQ(p.source, PositionSource::kRay);
  EXPECT_LT((p.p.normalized() - ray.normalized()).norm(), 1e-9);  // on the ray
  EXPECT_NEAR(p.p.norm(), 1.5, 0.05);
}

TEST(ObjectPositionTest, AGrazingRayOrTooFewPointsFallBack) {
  Eigen::Vector3d centre;
  const std::vector<Eigen::Vector3d> points = QuarterFace(4, 4, &centre);
  // Along the plane: its normal is (0.5, 0, 0.87), so (-0.87, 0, 0.5) grazes it.
  EXPECT_EQ(
      EstimateObjectPosition(points, Eigen::Vector3d(-0.866, 0, 0.5), ObjectRecognitionOptions())
          .source,
      PositionSource::kRay);
  const std::vector<Eigen::Vector3d> few(points.begin(), points.begin() + 5);
  EXPECT_EQ(
      EstimateObjectPosition(few, Eigen::Vector3d::UnitZ(), ObjectRecognitionOptions()).source,
      PositionSource::kRay);
  EXPECT_EQ(EstimateObjectPosition({}, Eigen::Vector3d::UnitZ(), ObjectRecognitionOptions()).p,
            Eigen::Vector3d::Zero());
}

TEST(ObjectPositionTest, DeterministicAndPercentile) {
  Eigen::Vector3d centre;
  const std::vector<Eigen::Vector3d> points = QuarterFace(6, 6, &centre);
  const ObjectPosition a = EstimateObjectPosition(points, Eigen::Vector3d::UnitZ(), {});
  const ObjectPosition b = EstimateObjectPosition(points, Eigen::Vector3d::UnitZ(), {});
  EXPECT_EQ(a.p, b.p);
  EXPECT_EQ(a.extent, b.extent);
  std::vector<double> v = {4, 1, 3, 2, 0};
  EXPECT_DOUBLE_EQ(Percentile(v, 50), 2.0);
  EXPECT_DOUBLE_EQ(Percentile(v, 10), 0.4);
  EXPECT_DOUBLE_EQ(Percentile(v, 100), 4.0);
}

}  // namespace
}  // namespace semmap
