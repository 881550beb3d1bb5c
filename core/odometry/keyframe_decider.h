// The question a front end asks for every placed frame: does it become a keyframe? Front ends
// (RGB-D tracking, known poses, monocular VO next) describe the frame; the answer is the slam
// module's KeyframePolicy (core/slam/keyframe_policy.h), the one place the rule lives. The
// interface is here so that odometry does not depend on slam.
#pragma once

#include <Eigen/Geometry>
#include <vector>

namespace semmap {

enum class KeyframeEvidence {
  kSegmentStart,  // first frame of a map segment (session start, re-initialisation)
  kTracked,       // tracked against the current reference keyframe / local map
  kRelocalised,   // placed against an older keyframe after the reference failed
  kKnownPose,     // the client gave the pose (KNOWN_POSES)
  kPredicted,     // the learned VO network's motion (MONO): the motion norm alone decides
};

struct KeyframeCandidate {
  KeyframeEvidence evidence = KeyframeEvidence::kTracked;
  Eigen::Isometry3d T_world_camera = Eigen::Isometry3d::Identity();
  bool has_depth = true;  // the frame's own depth (visual modes make keyframes only with it)
  int num_inliers = 0;    // kTracked: inliers of the pose estimate
  // kTracked: keyframes the map already holds around the frame (any session's, from the
  // back end's latest map update), null when none are known. A frame this close to one of
  // them shows nothing the map lacks (a revisit): motion alone does not make it a keyframe.
  const std::vector<Eigen::Isometry3d>* mapped_keyframes = nullptr;
};

class KeyframeDecider {
 public:
  virtual ~KeyframeDecider() = default;
  // True makes the frame the new reference keyframe. Called once per placed frame, in order.
  virtual bool Decide(const KeyframeCandidate& candidate) = 0;
  // The back end moved the map: the reference the rule measures from moved with it.
  virtual void ApplyCorrection(const Eigen::Isometry3d& T_corrected_world) = 0;
};

}  // namespace semmap
