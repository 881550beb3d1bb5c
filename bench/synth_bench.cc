// Speed of the synthetic RGB-D generator on one core: frames/s of the renderer at 640x480
// (plain, with sensor noise, with motion blur) along the circle trajectory, and the time to
// build the default scene (texture generation). Run: build/.../bench/synth_bench
#include <benchmark/benchmark.h>

#include <cstdio>
#include <cstdlib>
#include <opencv2/core/utility.hpp>

#include "tests/testing/synth/default_scene.h"
#include "tests/testing/synth/renderer.h"
#include "tests/testing/synth/sequence_frame.h"
#include "tests/testing/synth/sequence_writer.h"
#include "tests/testing/synth/trajectory.h"

namespace semmap::synth {
namespace {

struct Fixture {
  Scene scene;
  std::vector<StampedPose> trajectory;
};

const Fixture& SharedFixture() {
  static const Fixture* fixture = [] {
    StatusOr<Scene> scene = MakeDefaultRoomScene(1);
    if (!scene.ok()) {
      std::fprintf(stderr, "scene: %s\n", scene.status().ToString().c_str());
      std::abort();
    }
    StatusOr<std::vector<StampedPose>> poses = CircleTrajectory(scene->room, TrajectoryOptions{});
    if (!poses.ok()) std::abort();
    return new Fixture{std::move(scene).value(), std::move(poses).value()};
  }();
  return *fixture;
}

Renderer MakeRenderer(int width, int height) {
  StatusOr<Renderer> renderer =
      Renderer::Create(SharedFixture().scene, DefaultSyntheticCamera(width, height));
  if (!renderer.ok()) std::abort();
  return std::move(renderer).value();
}

void SetFrameCounters(benchmark::State& state) {
  state.counters["frames_per_s"] =
      benchmark::Counter(static_cast<double>(state.iterations()), benchmark::Counter::kIsRate);
}

void BM_Render(benchmark::State& state) {
  const Renderer renderer =
      MakeRenderer(static_cast<int>(state.range(0)), static_cast<int>(state.range(1)));
  const std::vector<StampedPose>& poses = SharedFixture().trajectory;
  RenderedFrame frame;
  size_t i = 0;
  for (auto _ : state) {
    renderer.Render(poses[i++ % poses.size()].T_world_camera, &frame);
    benchmark::DoNotOptimize(frame.bgr.data);
  }
  SetFrameCounters(state);
}
BENCHMARK(BM_Render)->Args({640, 480})->Args({320, 240})->Unit(benchmark::kMillisecond);

void BM_RenderSequenceFrame(benchmark::State& state, NoiseOptions noise) {
  const Renderer renderer = MakeRenderer(640, 480);
  const std::vector<StampedPose>& poses = SharedFixture().trajectory;
  size_t i = 0;
  for (auto _ : state) {
    RenderedFrame frame = RenderSequenceFrame(renderer, poses, i++ % poses.size(), noise, 7);
    benchmark::DoNotOptimize(frame.bgr.data);
  }
  SetFrameCounters(state);
}
BENCHMARK_CAPTURE(BM_RenderSequenceFrame, noise_640x480,
                  NoiseOptions{.depth_noise = true,
                               .drop_depth_probability = 0.02,
                               .colour_noise_sigma = 3.0})
    ->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_RenderSequenceFrame, blur_640x480, NoiseOptions{.motion_blur_samples = 24})
    ->Unit(benchmark::kMillisecond);

void BM_MakeDefaultRoomScene(benchmark::State& state) {
  uint64_t seed = 1;
  for (auto _ : state) {
    StatusOr<Scene> scene = MakeDefaultRoomScene(seed++);
    benchmark::DoNotOptimize(scene.ok());
  }
}
BENCHMARK(BM_MakeDefaultRoomScene)->Unit(benchmark::kMillisecond)->Iterations(3);

}  // namespace
}  // namespace semmap::synth

int main(int argc, char** argv) {
  cv::setNumThreads(1);  // one core: the renderer is single-threaded, keep OpenCV so too
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
