#include "tests/unit/recognition/recognition_eval.h"

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <opencv2/imgproc.hpp>
#include <utility>

#include "core/recognition/keyframe_recognition.h"
#include "tests/testing/synth/object_template.h"
#include "tests/unit/recognition/recognition_scene.h"

namespace semmap::recognition_test {
namespace {

enum class Truth { kPresent, kAbsent, kPartial };

// Pastes the photo of `object`, 150 px tall, left of the image centre.
Status PastePhoto(const synth::NamedObject& object, cv::Mat* bgr) {
  SEMMAP_ASSIGN_OR_RETURN(const cv::Mat photo, synth::RenderObjectTemplate(RoomRenderer(), object));
  const double scale = 150.0 / photo.rows;
  cv::Mat small;
  cv::resize(photo, small, cv::Size(std::max(1, static_cast<int>(photo.cols * scale)), 150), 0, 0,
             cv::INTER_AREA);
  const int w = std::min(small.cols, bgr->cols - 40);
  const cv::Rect where(60, (bgr->rows - small.rows) / 2, w, small.rows);
  small(cv::Rect(0, 0, w, small.rows)).copyTo((*bgr)(where));
  return OkStatus();
}

void Count(Truth truth, bool detected, LabelCounts* c) {
  switch (truth) {
    case Truth::kPresent:
      (detected ? c->true_positives : c->false_negatives)++;
      break;
    case Truth::kAbsent:
      if (detected) c->false_positives++;
      break;
    case Truth::kPartial:
      if (detected) c->partial_detections++;
      break;
  }
}

}  // namespace

double LabelCounts::Precision() const {
  const int d = true_positives + false_positives;
  return d == 0 ? 1.0 : static_cast<double>(true_positives) / d;
}

double LabelCounts::Recall() const {
  const int d = true_positives + false_negatives;
  return d == 0 ? 1.0 : static_cast<double>(true_positives) / d;
}

StatusOr<LapReport> EvaluateLap(const LapOptions& options) {
  if (options.keyframes < 3) return InvalidArgumentError("a lap needs at least 3 keyframes");
  synth::TrajectoryOptions t;
  t.frames = options.keyframes + 1;  // the last pose repeats the first
  SEMMAP_ASSIGN_OR_RETURN(const std::vector<StampedPose> poses,
                          synth::MakeTrajectory(options.trajectory, Room().room, t));
  const std::vector<synth::NamedObject>& objects = Room().objects;
  const std::vector<ObjectModel>& models = RoomModels();
  const size_t n = static_cast<size_t>(options.keyframes);

  std::vector<Keyframe> keyframes;
  std::vector<std::vector<Truth>> truth(n, std::vector<Truth>(objects.size(), Truth::kPartial));
  std::vector<std::vector<double>> visible(n, std::vector<double>(objects.size(), 0.0));
  std::vector<int> transient_label(n, -1);
  LapReport report;
  report.keyframes = options.keyframes;
  for (size_t k = 0; k < n; ++k) {
    keyframes.push_back(MakeKeyframe(poses[k].T_world_camera));
    Keyframe& kf = keyframes.back();
    for (size_t o = 0; o < objects.size(); ++o) {
      const double f = VisibleFraction(objects[o], kf.T_world_camera, kf.frame);
      visible[k][o] = f;
      if (f == 0.0) {
        truth[k][o] = Truth::kAbsent;
      } else if (f >= options.min_visible_fraction &&
                 ProjectedFaceMinSidePx(objects[o], kf.T_world_camera) >= options.min_face_px) {
        truth[k][o] = Truth::kPresent;
      }
    }
    const int every = options.transient_every;
    if (every > 0 && static_cast<int>(k) % every == every / 2) {
      // The first object this view does not see, starting from a different one each time.
      for (size_t i = 0; i < objects.size(); ++i) {
        const size_t o = (k / static_cast<size_t>(every) + i) % objects.size();
        if (truth[k][o] != Truth::kAbsent) continue;
        SEMMAP_RETURN_IF_ERROR(PastePhoto(objects[o], &kf.frame.bgr));
        kf.features = ExtractFeatures(kf.frame);
        transient_label[k] = static_cast<int>(o);
        ++report.transients;
        break;
      }
    }
  }

  double total_ms = 0;
  for (size_t k = 0; k < n; ++k) {
    // A closed lap: the previous and next keyframes, wrapping around.
    const std::vector<const FrameFeatures*> neighbours = {&keyframes[(k + n - 1) % n].features,
                                                          &keyframes[(k + 1) % n].features};
    SEMMAP_ASSIGN_OR_RETURN(const KeyframeRecognition plain,
                            RecogniseKeyframe(keyframes[k].features, RoomCamera(), neighbours,
                                              models, options.recognition, /*apply_xi=*/false));
    const auto start = std::chrono::steady_clock::now();
    SEMMAP_ASSIGN_OR_RETURN(const KeyframeRecognition checked,
                            RecogniseKeyframe(keyframes[k].features, RoomCamera(), neighbours,
                                              models, options.recognition));
    total_ms +=
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
    for (size_t o = 0; o < objects.size(); ++o) {
      bool without = false, with = false;
      for (const RecognisedObject& r : plain.found)
        without |= r.detection.model_index == static_cast<int>(o);
      for (const RecognisedObject* r : checked.Accepted()) {
        if (r->detection.model_index != static_cast<int>(o)) continue;
        with = true;
        if (truth[k][o] == Truth::kPresent && visible[k][o] == 1.0) {
          const Eigen::Vector3d p_world = keyframes[k].T_world_camera * r->detection.p_keyframe;
          report.position_errors_m.push_back((p_world - objects[o].front.Centre()).norm());
        }
      }
      Count(truth[k][o], without, &report.without_xi);
      Count(truth[k][o], with, &report.with_xi);
      if (transient_label[k] == static_cast<int>(o)) {
        report.transient_detections_without_xi += without;
        report.transient_detections_with_xi += with;
      }
    }
  }
  report.detect_ms_per_keyframe = total_ms / static_cast<double>(n);
  if (!report.position_errors_m.empty()) {
    std::vector<double> e = report.position_errors_m;
    std::sort(e.begin(), e.end());
    report.max_position_error_m = e.back();
    report.median_position_error_m = e[e.size() / 2];
  }
  return report;
}

std::string FormatLapReport(const LapReport& r) {
  char buf[1024];
  const auto line = [](const char* name, const LabelCounts& c, int transients) {
    char b[256];
    std::snprintf(b, sizeof(b),
                  "  %-11s precision %.3f recall %.3f (TP %d FP %d FN %d, partial %d, "
                  "transient pictures detected %d)\n",
                  name, c.Precision(), c.Recall(), c.true_positives, c.false_positives,
                  c.false_negatives, c.partial_detections, transients);
    return std::string(b);
  };
  std::snprintf(buf, sizeof(buf),
                "lap: %d keyframes, %d with a transient picture; position error (whole face "
                "in view, n=%zu): median %.4f m, max %.4f m; %.2f ms per keyframe\n",
                r.keyframes, r.transients, r.position_errors_m.size(), r.median_position_error_m,
                r.max_position_error_m, r.detect_ms_per_keyframe);
  return buf + line("without xi", r.without_xi, r.transient_detections_without_xi) +
         line("with xi", r.with_xi, r.transient_detections_with_xi);
}

}  // namespace semmap::recognition_test
