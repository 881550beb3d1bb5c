// Micro-benchmarks of the trajectory evaluation: ATE (association + alignment + statistics) on
// 10k and 100k poses, RPE, the KITTI metric on a sequence-00-sized path, and the figures.
#include <benchmark/benchmark.h>
#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include "client/eval/ate.h"
#include "client/eval/kitti_metric.h"
#include "client/eval/plot.h"
#include "client/eval/rpe.h"

namespace semmap {
namespace {

constexpr int64_t kT0 = 1'341'841'873'415'100'000;
constexpr int64_t kMs = 1'000'000;

// A 100 Hz ground truth on a wavy loop and a 3 ms-late, rotated, noisy estimate of it.
void MakeTrajectories(size_t n, std::vector<StampedPose>* gt, std::vector<StampedPose>* est) {
  gt->clear();
  est->clear();
  const Eigen::Matrix3d R =
      Eigen::AngleAxisd(0.4, Eigen::Vector3d(0.2, 0.3, 1).normalized()).toRotationMatrix();
  for (size_t i = 0; i < n; ++i) {
    const double a = 2e-3 * static_cast<double>(i);
    StampedPose p;
    p.stamp_ns = kT0 + static_cast<int64_t>(i) * 10 * kMs;
    p.T_world_camera.translation() =
        Eigen::Vector3d(5 * std::cos(a), 3 * std::sin(a), 0.5 * std::sin(7 * a));
    p.T_world_camera.linear() = Eigen::AngleAxisd(a, Eigen::Vector3d::UnitZ()).toRotationMatrix();
    gt->push_back(p);
    StampedPose q = p;
    q.stamp_ns += 3 * kMs;
    const double k = static_cast<double>(i);
    q.T_world_camera.translation() =
        R * p.T_world_camera.translation() +
        Eigen::Vector3d(0.02 * std::sin(1.3 * k), 0.02 * std::cos(0.7 * k), 0.01 * std::sin(k));
    q.T_world_camera.linear() = R * p.T_world_camera.linear();
    est->push_back(q);
  }
}

void BM_ComputeAte(benchmark::State& state) {
  std::vector<StampedPose> gt, est;
  MakeTrajectories(static_cast<size_t>(state.range(0)), &gt, &est);
  for (auto _ : state) {
    StatusOr<AteResult> ate = ComputeAte(gt, est);
    if (!ate.ok()) state.SkipWithError(ate.status().ToString().c_str());
    benchmark::DoNotOptimize(ate);
  }
  state.SetItemsProcessed(state.iterations() * state.range(0));
}
BENCHMARK(BM_ComputeAte)->Arg(10'000)->Arg(100'000)->Unit(benchmark::kMillisecond);

void BM_ComputeAteWithScale(benchmark::State& state) {
  std::vector<StampedPose> gt, est;
  MakeTrajectories(static_cast<size_t>(state.range(0)), &gt, &est);
  AteOptions options;
  options.estimate_scale = true;
  for (auto _ : state) {
    StatusOr<AteResult> ate = ComputeAte(gt, est, options);
    if (!ate.ok()) state.SkipWithError(ate.status().ToString().c_str());
    benchmark::DoNotOptimize(ate);
  }
  state.SetItemsProcessed(state.iterations() * state.range(0));
}
BENCHMARK(BM_ComputeAteWithScale)->Arg(10'000)->Unit(benchmark::kMillisecond);

void BM_ComputeRpe(benchmark::State& state) {
  std::vector<StampedPose> gt, est;
  MakeTrajectories(static_cast<size_t>(state.range(0)), &gt, &est);
  for (auto _ : state) {
    StatusOr<RpeResult> rpe = ComputeRpe(gt, est);
    if (!rpe.ok()) state.SkipWithError(rpe.status().ToString().c_str());
    benchmark::DoNotOptimize(rpe);
  }
  state.SetItemsProcessed(state.iterations() * state.range(0));
}
BENCHMARK(BM_ComputeRpe)->Arg(10'000)->Arg(100'000)->Unit(benchmark::kMillisecond);

void BM_KittiMetric(benchmark::State& state) {
  // 4541 frames over ~3.7 km, like KITTI sequence 00.
  std::vector<StampedPose> gt, est;
  for (int i = 0; i < 4541; ++i) {
    const double a = 1.5e-3 * i;
    StampedPose p;
    p.stamp_ns = i;
    p.T_world_camera.translation() = Eigen::Vector3d(600 * std::sin(a), 0, 600 * (1 - std::cos(a)));
    p.T_world_camera.linear() = Eigen::AngleAxisd(a, Eigen::Vector3d::UnitY()).toRotationMatrix();
    gt.push_back(p);
    p.T_world_camera.translation() *= 1.01;
    est.push_back(p);
  }
  for (auto _ : state) {
    StatusOr<KittiResult> r = ComputeKittiMetric(gt, est);
    if (!r.ok()) state.SkipWithError(r.status().ToString().c_str());
    benchmark::DoNotOptimize(r);
  }
}
BENCHMARK(BM_KittiMetric)->Unit(benchmark::kMillisecond);

void BM_RenderTrajectoryPlot(benchmark::State& state) {
  std::vector<StampedPose> gt, est;
  MakeTrajectories(static_cast<size_t>(state.range(0)), &gt, &est);
  const AteResult ate = ComputeAte(gt, est).value();
  for (auto _ : state) {
    StatusOr<cv::Mat> image = RenderTrajectoryPlot(ate);
    if (!image.ok()) state.SkipWithError(image.status().ToString().c_str());
    benchmark::DoNotOptimize(image);
  }
}
BENCHMARK(BM_RenderTrajectoryPlot)->Arg(10'000)->Arg(100'000)->Unit(benchmark::kMillisecond);

void BM_PlotTrajectoryPng(benchmark::State& state) {
  std::vector<StampedPose> gt, est;
  MakeTrajectories(10'000, &gt, &est);
  const AteResult ate = ComputeAte(gt, est).value();
  const std::string path = "/tmp/semmap_eval_bench_" + std::to_string(::getpid()) + ".png";
  for (auto _ : state) {
    Status s = PlotTrajectory(ate, path);
    if (!s.ok()) state.SkipWithError(s.ToString().c_str());
  }
  std::remove(path.c_str());
}
BENCHMARK(BM_PlotTrajectoryPng)->Unit(benchmark::kMillisecond);

void BM_RenderErrorPlot(benchmark::State& state) {
  std::vector<StampedPose> gt, est;
  MakeTrajectories(10'000, &gt, &est);
  const AteResult ate = ComputeAte(gt, est).value();
  for (auto _ : state) {
    StatusOr<cv::Mat> image = RenderErrorPlot(ate);
    if (!image.ok()) state.SkipWithError(image.status().ToString().c_str());
    benchmark::DoNotOptimize(image);
  }
}
BENCHMARK(BM_RenderErrorPlot)->Unit(benchmark::kMillisecond);

}  // namespace
}  // namespace semmap

BENCHMARK_MAIN();
