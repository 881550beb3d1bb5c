// RGB-D bundle adjustment (core/slam) on a local-window-sized problem: 24 keyframes on an arc
// (the oldest 16 fixed, as a local BA's window), 3000 points each seen by every keyframe whose
// image it falls in, with depth; poses perturbed by ~2 cm / 1 deg and points by ~3 cm.
//   BM_LocalWindow/0   the Schur complement solved sparsely (SuiteSparse where built in)
//   BM_LocalWindow/1   solved densely (dense_schur_max_keyframes >= 24, the default)
// Both run the default 5 robust + 10 refine iterations without a time bound; the counters give
// observations and the final cost, so the two can be checked to reach the same solution.
#include <benchmark/benchmark.h>

#include <cmath>
#include <random>
#include <vector>

#include "core/slam/bundle_adjustment.h"

namespace semmap {
namespace {

struct Problem {
  std::vector<BundleAdjustmentKeyframe> keyframes;
  std::vector<BundleAdjustmentPoint> points;
  std::vector<BundleAdjustmentObservation> observations;
};

Problem MakeProblem() {
  CameraCalibration camera;
  camera.width = 640;
  camera.height = 480;
  camera.fx = camera.fy = 525;
  camera.cx = 319.5;
  camera.cy = 239.5;
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-1, 1);
  std::normal_distribution<double> n(0, 1);
  Problem problem;
  std::vector<Eigen::Isometry3d> truth;
  for (int k = 0; k < 24; ++k) {
    const double a = (k - 11.5) * 0.06;
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    T.translation() << 3 * std::sin(a), 0.01 * k, 3 - 3 * std::cos(a);
    T.linear() = Eigen::AngleAxisd(-a, Eigen::Vector3d::UnitY()).toRotationMatrix();
    truth.push_back(T);
    Eigen::Isometry3d start = T;
    if (k >= 16) {
      const Eigen::Vector3d w(n(rng), n(rng), n(rng));
      start.linear() =
          T.linear() * Eigen::AngleAxisd(M_PI / 180, w.normalized()).toRotationMatrix();
      start.translation() += 0.02 * Eigen::Vector3d(n(rng), n(rng), n(rng)).normalized();
    }
    problem.keyframes.push_back({k, start, camera, k < 16});
  }
  for (int i = 0; i < 3000; ++i) {
    const Eigen::Vector3d p(4 * u(rng), 1.1 * u(rng), 2.5 + 0.5 * u(rng));
    problem.points.push_back({i, p + 0.03 * Eigen::Vector3d(n(rng), n(rng), n(rng)), false});
    for (int k = 0; k < 24; ++k) {
      const Eigen::Vector3d c = truth[static_cast<size_t>(k)].inverse() * p;
      const Eigen::Vector2d px(camera.fx * c.x() / c.z() + camera.cx,
                               camera.fy * c.y() / c.z() + camera.cy);
      if (px.x() < 0 || px.y() < 0 || px.x() >= camera.width || px.y() >= camera.height) continue;
      problem.observations.push_back({k, i, px, 1.0, 1 / c.z()});
    }
  }
  return problem;
}

void BM_LocalWindow(benchmark::State& state) {
  static const Problem problem = MakeProblem();
  BundleAdjustmentOptions options;
  options.dense_schur_max_keyframes = state.range(0) == 1 ? 64 : 0;
  double final_cost = 0;
  for (auto _ : state) {
    StatusOr<BundleAdjustmentResult> result =
        BundleAdjust(problem.keyframes, problem.points, problem.observations, options);
    if (!result.ok()) {
      state.SkipWithError(result.status().ToString().c_str());
      return;
    }
    final_cost = result->final_cost;
  }
  state.counters["observations"] = static_cast<double>(problem.observations.size());
  state.counters["final_cost"] = final_cost;
}
BENCHMARK(BM_LocalWindow)->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond);

}  // namespace
}  // namespace semmap

BENCHMARK_MAIN();
