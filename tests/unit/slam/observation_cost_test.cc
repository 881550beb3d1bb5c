#include "core/slam/internal/observation_cost.h"

#include <ceres/autodiff_cost_function.h>
#include <gtest/gtest.h>

#include <random>

namespace semmap::slam_internal {
namespace {

// The residual as automatic differentiation sees it (what BundleAdjust used before the
// analytic Jacobians): the reference the analytic ones must match.
template <int kResiduals>
struct ReferenceResidual {
  ObservationModel m;

  template <typename T>
  bool operator()(const T* t_ptr, const T* q_ptr, const T* x_ptr, T* r) const {
    using Vec3 = Eigen::Matrix<T, 3, 1>;
    const Eigen::Map<const Vec3> t(t_ptr), x(x_ptr);
    const Eigen::Map<const Eigen::Quaternion<T>> q(q_ptr);
    const Vec3 p = q.conjugate() * (x - t);
    if (p.z() <= T(1e-6)) return false;
    const T iz = T(1) / p.z();
    r[0] = (T(m.fx) * p.x() * iz + T(m.cx) - T(m.u)) * T(m.inverse_pixel_sigma);
    r[1] = (T(m.fy) * p.y() * iz + T(m.cy) - T(m.v)) * T(m.inverse_pixel_sigma);
    if constexpr (kResiduals == 3) {
      r[2] = (iz - T(m.inverse_depth)) * T(m.inverse_inverse_depth_sigma);
    }
    return true;
  }
};

template <int kResiduals>
void ExpectAnalyticMatchesAutodiff(uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-1, 1);
  ObservationModel model;
  model.fx = 520 + 10 * u(rng);
  model.fy = 515 + 10 * u(rng);
  model.cx = 320 + 5 * u(rng);
  model.cy = 240 + 5 * u(rng);
  model.u = 320 + 200 * u(rng);
  model.v = 240 + 150 * u(rng);
  model.inverse_pixel_sigma = 1 / 1.44;
  model.inverse_depth = 0.4;
  model.inverse_inverse_depth_sigma = 1 / 3e-3;
  const ObservationCost<kResiduals> analytic(model);
  const ceres::AutoDiffCostFunction<ReferenceResidual<kResiduals>, kResiduals, 3, 4, 3> autodiff(
      new ReferenceResidual<kResiduals>{model});
  for (int trial = 0; trial < 50; ++trial) {
    const Eigen::Quaterniond q = Eigen::Quaterniond(
        Eigen::AngleAxisd(u(rng) * M_PI, Eigen::Vector3d(u(rng), u(rng), u(rng)).normalized()));
    const Eigen::Vector3d t(u(rng), u(rng), u(rng));
    // A point 1-4 m in front of the camera.
    const Eigen::Vector3d p_c(u(rng), u(rng), 2.5 + 1.5 * u(rng));
    const Eigen::Vector3d x = q * p_c + t;
    const double* parameters[3] = {t.data(), q.coeffs().data(), x.data()};
    double r_analytic[kResiduals], r_autodiff[kResiduals];
    double ja[3][kResiduals * 4], jr[3][kResiduals * 4];
    double* jacobians_analytic[3] = {ja[0], ja[1], ja[2]};
    double* jacobians_autodiff[3] = {jr[0], jr[1], jr[2]};
    ASSERT_TRUE(analytic.Evaluate(parameters, r_analytic, jacobians_analytic));
    ASSERT_TRUE(autodiff.Evaluate(parameters, r_autodiff, jacobians_autodiff));
    for (int i = 0; i < kResiduals; ++i) EXPECT_NEAR(r_analytic[i], r_autodiff[i], 1e-9);
    const int sizes[3] = {3, 4, 3};
    for (int block = 0; block < 3; ++block) {
      for (int i = 0; i < kResiduals * sizes[block]; ++i) {
        const double scale = std::max(1.0, std::abs(jr[block][i]));
        EXPECT_NEAR(ja[block][i], jr[block][i], 1e-9 * scale)
            << "block " << block << " entry " << i << " trial " << trial;
      }
    }
  }
}

TEST(ObservationCostTest, AnalyticJacobiansMatchAutomaticDifferentiation) {
  ExpectAnalyticMatchesAutodiff<3>(1);
  ExpectAnalyticMatchesAutodiff<2>(2);
}

TEST(ObservationCostTest, APointBehindTheCameraIsInfeasible) {
  ObservationModel model;
  model.fx = model.fy = 500;
  const ObservationCost<3> cost(model);
  const Eigen::Vector3d t = Eigen::Vector3d::Zero(), x(0, 0, -1);
  const Eigen::Quaterniond q = Eigen::Quaterniond::Identity();
  const double* parameters[3] = {t.data(), q.coeffs().data(), x.data()};
  double residuals[3];
  EXPECT_FALSE(cost.Evaluate(parameters, residuals, nullptr));
}

}  // namespace
}  // namespace semmap::slam_internal
