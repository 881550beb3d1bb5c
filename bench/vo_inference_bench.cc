// The learned VO network as MONO sessions run it (core/odometry/mono_vo), on the shipped model:
// one recurrent step on one thread at the network's input size, the canonical resampling of a
// 640x480 frame, the predicted depth mapped back to it, and the model's load time. Skips with a
// message when models/vo/semmap_vo.onnx is absent.
#include <benchmark/benchmark.h>

#include <chrono>
#include <filesystem>
#include <opencv2/core/utility.hpp>
#include <opencv2/imgproc.hpp>

#include "core/odometry/canonical_camera.h"
#include "core/odometry/mono_vo.h"
#include "core/odometry/mono_vo_model.h"
#include "tests/testing/pinhole_camera.h"

namespace semmap {
namespace {

const std::string kModel = std::string(SEMMAP_SOURCE_DIR) + "/models/vo/semmap_vo.onnx";

std::shared_ptr<const MonoVoModel> Model(benchmark::State& state) {
  static StatusOr<std::shared_ptr<const MonoVoModel>> model =
      std::filesystem::exists(kModel) ? MonoVoModel::Load(kModel)
                                      : StatusOr<std::shared_ptr<const MonoVoModel>>(
                                            NotFoundError("no trained model at " + kModel));
  if (!model.ok()) {
    state.SkipWithError(model.status().ToString().c_str());
    return nullptr;
  }
  return *model;
}

CameraCalibration Camera640() { return testing::PinholeCamera(640, 480, 525); }

cv::Mat Textured(int w, int h, int shift) {
  cv::Mat image(h, w, CV_8UC3);
  cv::randu(image, cv::Scalar::all(0), cv::Scalar::all(255));
  cv::Mat shifted;
  const cv::Matx23d m(1, 0, shift, 0, 1, 0);
  cv::warpAffine(image, shifted, m, image.size(), cv::INTER_LINEAR, cv::BORDER_REFLECT);
  return shifted;
}

void BM_NetworkStepOneThread(benchmark::State& state) {
  std::shared_ptr<const MonoVoModel> model = Model(state);
  if (!model) return;
  cv::setNumThreads(1);
  std::unique_ptr<MonoVoRunner> runner = model->NewRunner().value();
  const CanonicalCamera& c = model->info().camera;
  const cv::Mat a = Textured(c.width, c.height, 0), b = Textured(c.width, c.height, 2);
  int i = 0;
  for (auto _ : state) {
    StatusOr<MonoVoStep> step = runner->Step(++i % 2 == 0 ? a : b);
    if (!step.ok()) state.SkipWithError(step.status().ToString().c_str());
    benchmark::DoNotOptimize(step);
  }
}
BENCHMARK(BM_NetworkStepOneThread)->Unit(benchmark::kMillisecond)->MinTime(2.0);

void BM_ResampleToCanonical640x480(benchmark::State& state) {
  std::shared_ptr<const MonoVoModel> model = Model(state);
  if (!model) return;
  cv::setNumThreads(1);
  const CanonicalResampler r =
      CanonicalResampler::Create(Camera640(), model->info().camera).value();
  const cv::Mat frame = Textured(640, 480, 0);
  for (auto _ : state) benchmark::DoNotOptimize(r.ToCanonical(frame));
}
BENCHMARK(BM_ResampleToCanonical640x480)->Unit(benchmark::kMillisecond);

void BM_DepthBackTo640x480(benchmark::State& state) {
  std::shared_ptr<const MonoVoModel> model = Model(state);
  if (!model) return;
  cv::setNumThreads(1);
  const CanonicalResampler r =
      CanonicalResampler::Create(Camera640(), model->info().camera).value();
  const CanonicalCamera& c = model->info().camera;
  const cv::Mat depth(c.height, c.width, CV_32F, cv::Scalar(2.0f));
  for (auto _ : state) benchmark::DoNotOptimize(r.DepthToCamera(depth, 5000.0));
}
BENCHMARK(BM_DepthBackTo640x480)->Unit(benchmark::kMillisecond);

void BM_ModelLoad(benchmark::State& state) {
  if (!std::filesystem::exists(kModel)) {
    state.SkipWithError("no trained model");
    return;
  }
  for (auto _ : state) benchmark::DoNotOptimize(MonoVoModel::Load(kModel));
}
BENCHMARK(BM_ModelLoad)->Unit(benchmark::kMillisecond)->Iterations(5);

}  // namespace
}  // namespace semmap

BENCHMARK_MAIN();
