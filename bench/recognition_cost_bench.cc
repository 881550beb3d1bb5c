// Cost of recognition per keyframe against the number of registered object types (1, 10, 50),
// printed as figures (`make bench`). The 50 types are the room's 4 objects and 46
// synthetic object photos (the scene generator's object textures with captions).
#include <chrono>
#include <cstdio>
#include <string>
#include <vector>

#include "common/time_util.h"
#include "core/recognition/keyframe_recognition.h"
#include "core/recognition/object_detector.h"
#include "tests/testing/synth/texture.h"
#include "tests/testing/synth/trajectory.h"
#include "tests/unit/recognition/recognition_scene.h"

namespace semmap {
namespace {

using namespace recognition_test;
using Clock = std::chrono::steady_clock;

int Fail(const Status& status) {
  std::fprintf(stderr, "recognition_cost_bench: %s\n", status.ToString().c_str());
  return 1;
}

// Exits 1 with a message when the fixture or recognition fails.
int Run() {
  std::vector<ObjectModel> models = RoomModels();
  const auto build_start = Clock::now();
  for (int i = static_cast<int>(models.size()); i < 50; ++i) {
    StatusOr<cv::Mat> photo =
        synth::GenerateTexture(300, 400, synth::TextureStyle::kObject,
                               1000 + static_cast<uint64_t>(i), "OBJ" + std::to_string(i));
    if (!photo.ok()) return Fail(photo.status());
    StatusOr<ObjectModel> m =
        BuildObjectModel(i + 1, "extra_" + std::to_string(i), {*photo}, ObjectRecognitionOptions());
    if (!m.ok()) return Fail(m.status());
    models.push_back(std::move(m).value());
  }
  const double build_ms = MillisecondsSince(build_start) / (50.0 - 4.0);
  size_t features = 0;
  for (const ObjectModel& m : models) features += m.views[0].features.size();

  synth::TrajectoryOptions t;
  t.frames = 25;
  StatusOr<std::vector<StampedPose>> poses = synth::CircleTrajectory(Room().room, t);
  if (!poses.ok()) return Fail(poses.status());
  std::vector<Keyframe> kfs;
  kfs.reserve(24);
  for (int k = 0; k < 24; ++k)
    kfs.push_back(MakeKeyframe((*poses)[static_cast<size_t>(k)].T_world_camera));
  size_t kf_features = 0;
  for (const Keyframe& kf : kfs) kf_features += kf.features.size();

  std::printf("model: %.1f ms per photo, %.0f features per view; keyframes: %.0f features\n",
              build_ms, static_cast<double>(features) / 50.0,
              static_cast<double>(kf_features) / static_cast<double>(kfs.size()));
  for (size_t n : {size_t{1}, size_t{10}, size_t{50}}) {
    const std::vector<ObjectModel> subset(models.begin(), models.begin() + static_cast<long>(n));
    int detections = 0;
    auto start = Clock::now();
    for (const Keyframe& kf : kfs) {
      StatusOr<KeyframeDetections> d =
          DetectObjects(kf.features, RoomCamera(), subset, ObjectRecognitionOptions());
      if (!d.ok()) return Fail(d.status());
      detections += static_cast<int>(d->detections.size());
    }
    const double detect_ms = MillisecondsSince(start) / static_cast<double>(kfs.size());
    start = Clock::now();
    for (size_t k = 0; k < kfs.size(); ++k) {
      StatusOr<KeyframeRecognition> r = RecogniseKeyframe(
          kfs[k].features, RoomCamera(),
          {&kfs[(k + kfs.size() - 1) % kfs.size()].features, &kfs[(k + 1) % kfs.size()].features},
          subset, ObjectRecognitionOptions());
      if (!r.ok()) return Fail(r.status());
    }
    const double with_xi_ms = MillisecondsSince(start) / static_cast<double>(kfs.size());
    std::printf(
        "%2zu types: DetectObjects %6.2f ms per keyframe (%.2f ms per type), with the xi check "
        "%6.2f ms; %d detections in %zu keyframes\n",
        n, detect_ms, detect_ms / static_cast<double>(n), with_xi_ms, detections, kfs.size());
  }
  return 0;
}

}  // namespace
}  // namespace semmap

int main() { return semmap::Run(); }
