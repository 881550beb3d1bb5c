// Keyframe-label precision and recall of object recognition on a synthetic lap through the
// default room, with and without the xi neighbour check, so that what the check buys (and
// costs) can be measured and reported. Callable from any test or tool that links
// semmap_recognition_testing.
//
// Each keyframe of the lap is labelled with the objects detected in it; the truth per
// (keyframe, object):
//   present  the view sees >= min_visible_fraction of the front face, at least min_face_px
//            across: a miss is a false negative;
//   absent   no point of the front face is visible (VisibleFraction 0): a detection is a false
//            positive;
//   partial  anything between (entering or leaving the view, grazing, tiny): not counted
//            either way.
// With `transient_every` > 0, every so many keyframes get a transient picture: the photo of
// an object that keyframe does not see pasted into the image (a page held up, a screen), which
// is absent from the room, and its neighbours do not show it; detecting it is a false positive.
#pragma once

#include <string>
#include <vector>

#include "common/status.h"
#include "core/recognition/object_model.h"
#include "tests/testing/synth/trajectory.h"

namespace semmap::recognition_test {

struct LapOptions {
  synth::TrajectoryKind trajectory = synth::TrajectoryKind::kCircle;
  int keyframes = 72;       // over one lap (5 degrees apart on the circle)
  int transient_every = 0;  // 0: none
  ObjectRecognitionOptions recognition;
  double min_visible_fraction = 0.6;
  double min_face_px = 40;
};

struct LabelCounts {
  int true_positives = 0;
  int false_positives = 0;
  int false_negatives = 0;
  int partial_detections = 0;  // detections of partly visible objects (not counted)
  double Precision() const;    // 1 when nothing was detected
  double Recall() const;       // 1 when nothing was to be found
};

struct LapReport {
  int keyframes = 0;
  int transients = 0;  // keyframes with a pasted picture
  LabelCounts without_xi;
  LabelCounts with_xi;
  int transient_detections_without_xi = 0;  // pasted pictures detected (false positives)
  int transient_detections_with_xi = 0;
  // Position errors (m) of true positives that see the whole front face, against its centre.
  std::vector<double> position_errors_m;
  double max_position_error_m = 0;
  double median_position_error_m = 0;
  double detect_ms_per_keyframe = 0;  // DetectObjects + xi (neighbour matching), mean
};

StatusOr<LapReport> EvaluateLap(const LapOptions& options);

// A few lines for a test's output.
std::string FormatLapReport(const LapReport& report);

}  // namespace semmap::recognition_test
