#include "core/recognition/keyframe_recognition.h"

#include <utility>

namespace semmap {

std::vector<const RecognisedObject*> KeyframeRecognition::Accepted() const {
  std::vector<const RecognisedObject*> out;
  for (const RecognisedObject& r : found) {
    if (r.xi.accepted()) out.push_back(&r);
  }
  return out;
}

StatusOr<KeyframeRecognition> RecogniseKeyframe(const FrameFeatures& keyframe,
                                                const CameraCalibration& camera,
                                                const std::vector<const FrameFeatures*>& neighbours,
                                                const std::vector<ObjectModel>& models,
                                                const ObjectRecognitionOptions& options,
                                                bool apply_xi) {
  for (const FrameFeatures* n : neighbours) {
    if (n == nullptr) return InvalidArgumentError("a neighbour keyframe is null");
  }
  SEMMAP_ASSIGN_OR_RETURN(KeyframeDetections detections,
                          DetectObjects(keyframe, camera, models, options));
  KeyframeRecognition out;
  out.good_matches = std::move(detections.good_matches);
  for (ObjectDetection& d : detections.detections) {
    RecognisedObject r;
    const int n_c = out.good_matches[static_cast<size_t>(d.model_index)];
    if (apply_xi) {
      std::vector<int> counts;
      counts.reserve(neighbours.size());
      for (const FrameFeatures* n : neighbours) {
        SEMMAP_ASSIGN_OR_RETURN(
            const int count,
            CountGoodMatches(models[static_cast<size_t>(d.model_index)], *n, options.matcher));
        counts.push_back(count);
      }
      r.xi = CheckXi(n_c, counts, options.max_xi);
    } else {
      r.xi.n_c = n_c;
    }
    r.detection = std::move(d);
    out.found.push_back(std::move(r));
  }
  return out;
}

}  // namespace semmap
