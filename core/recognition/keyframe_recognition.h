// One keyframe's recognition step as the server runs it: DetectObjects on the keyframe, then
// the neighbour check (common/xi_check.h) for each detection against its neighbouring keyframes,
// which are matched only for the models detected (one matching pass per view and neighbour).
#pragma once

#include <vector>

#include "common/status.h"
#include "common/xi_check.h"
#include "core/recognition/object_detector.h"
#include "core/recognition/object_model.h"
#include "core/sensor/frame_features.h"

namespace semmap {

struct RecognisedObject {
  ObjectDetection detection;
  XiDecision xi;
};

struct KeyframeRecognition {
  std::vector<int> good_matches;        // per model, as KeyframeDetections::good_matches
  std::vector<RecognisedObject> found;  // every detection with its xi decision, in model order

  // The detections that passed the neighbour check.
  std::vector<const RecognisedObject*> Accepted() const;
};

// `neighbours`: features of the keyframes next to `keyframe` (the previous and next ones, or
// its covisible ones), in any order; null entries are INVALID_ARGUMENT. With
// `apply_xi` false every detection is accepted and the neighbours are not matched (xi 0): the
// check's baseline. Errors as DetectObjects.
StatusOr<KeyframeRecognition> RecogniseKeyframe(const FrameFeatures& keyframe,
                                                const CameraCalibration& camera,
                                                const std::vector<const FrameFeatures*>& neighbours,
                                                const std::vector<ObjectModel>& models,
                                                const ObjectRecognitionOptions& options,
                                                bool apply_xi = true);

}  // namespace semmap
