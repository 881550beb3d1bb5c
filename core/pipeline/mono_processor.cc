#include "core/pipeline/mono_processor.h"

#include <string>
#include <utility>

namespace semmap {
namespace {

// The pose graph's weight of one network step (it reports no uncertainty): about 2 cm and
// 1 degree per keyframe, weaker than a well-tracked RGB-D frame.
Eigen::Matrix<double, 6, 6> NetworkInformation() {
  Eigen::Matrix<double, 6, 1> sigma;
  sigma << 0.02, 0.02, 0.02, 0.0175, 0.0175, 0.0175;
  return sigma.cwiseInverse().cwiseAbs2().asDiagonal();
}

}  // namespace

StatusOr<std::unique_ptr<MonoProcessor>> MonoProcessor::Create(
    std::shared_ptr<const MonoVoModel> model, MonoVoMethod method,
    const KeyframePolicyOptions& keyframes, RgbdTrackerOptions tracker,
    const CameraCalibration& camera) {
  if (model == nullptr) return FailedPreconditionError("MONO sessions need the VO model");
  if (int64_t{camera.width} * camera.height > kMaxMonoCameraPixels) {
    return InvalidArgumentError("MONO sessions take cameras up to 4 MP (this one is " +
                                std::to_string(camera.width) + "x" + std::to_string(camera.height) +
                                "); resize the frames and the calibration on the client");
  }
  SEMMAP_RETURN_IF_ERROR(keyframes.Validate());
  SEMMAP_ASSIGN_OR_RETURN(CanonicalResampler resampler,
                          CanonicalResampler::Create(camera, model->info().camera));
  SEMMAP_ASSIGN_OR_RETURN(std::unique_ptr<MonoVoRunner> runner, model->NewRunner());
  SEMMAP_ASSIGN_OR_RETURN(FeatureExtractor extractor,
                          FeatureExtractor::Create(tracker.features, camera));
  std::optional<RgbdTracker> rgbd;
  if (method == MonoVoMethod::kHybrid) {
    tracker.camera = camera;
    SEMMAP_ASSIGN_OR_RETURN(
        RgbdTracker created,
        RgbdTracker::Create(tracker, std::make_unique<KeyframePolicy>(keyframes)));
    rgbd.emplace(std::move(created));
  }
  return std::unique_ptr<MonoProcessor>(
      new MonoProcessor(std::move(model), method, std::move(resampler), std::move(runner),
                        KeyframePolicy(keyframes), std::move(extractor), std::move(rgbd)));
}

MonoProcessor::MonoProcessor(std::shared_ptr<const MonoVoModel> model, MonoVoMethod method,
                             CanonicalResampler resampler, std::unique_ptr<MonoVoRunner> runner,
                             KeyframePolicy keyframes, FeatureExtractor extractor,
                             std::optional<RgbdTracker> tracker)
    : model_(std::move(model)),
      method_(method),
      resampler_(std::move(resampler)),
      runner_(std::move(runner)),
      keyframes_(std::move(keyframes)),
      extractor_(std::move(extractor)),
      tracker_(std::move(tracker)) {}

StatusOr<FrameEstimate> MonoProcessor::Process(const DecodedFrame& frame) {
  const std::string where = "frame seq " + std::to_string(frame.seq);
  SEMMAP_ASSIGN_OR_RETURN(const cv::Mat canonical, resampler_.ToCanonical(frame.colour));
  StatusOr<MonoVoStep> step = runner_->Step(canonical);
  if (!step.ok()) {
    // An implausible output restarts the network's sequence; the pose is held meanwhile.
    if (step.status().code() != StatusCode::kInvalidArgument)
      return step.status().WithContext(where);
    runner_->Reset();
    SEMMAP_ASSIGN_OR_RETURN(step, runner_->Step(canonical));
  }
  DecodedDepth depth;
  depth.depth_scale = kPredictedDepthScale;
  SEMMAP_ASSIGN_OR_RETURN(depth.raw, resampler_.DepthToCamera(step->depth, kPredictedDepthScale));
  StatusOr<FrameEstimate> estimate = method_ == MonoVoMethod::kNet
                                         ? ProcessNet(frame, *step, depth)
                                         : ProcessHybrid(frame, *step, depth);
  if (!estimate.ok()) return estimate.status().WithContext(where);
  T_world_last_ = estimate->T_world_camera;
  estimate->predicted_depth = std::move(depth);
  return estimate;
}

StatusOr<FrameEstimate> MonoProcessor::ProcessNet(const DecodedFrame& frame, const MonoVoStep& step,
                                                  const DecodedDepth& depth) {
  FrameEstimate estimate;
  KeyframeCandidate candidate;
  if (!T_world_last_) {
    candidate.evidence = KeyframeEvidence::kSegmentStart;  // identity: the session's origin
  } else {
    candidate.evidence = KeyframeEvidence::kPredicted;
    estimate.T_world_camera =
        *T_world_last_ * step.T_prev_cur.value_or(Eigen::Isometry3d::Identity());
  }
  candidate.T_world_camera = estimate.T_world_camera;
  estimate.is_keyframe = keyframes_.Decide(candidate);
  estimate.information = NetworkInformation();
  if (estimate.is_keyframe) {
    SEMMAP_ASSIGN_OR_RETURN(FrameFeatures features,
                            extractor_.Extract(frame.colour, depth.raw, depth.depth_scale));
    estimate.keyframe_features = std::make_shared<const FrameFeatures>(std::move(features));
  }
  return estimate;
}

StatusOr<FrameEstimate> MonoProcessor::ProcessHybrid(const DecodedFrame& frame,
                                                     const MonoVoStep& step,
                                                     const DecodedDepth& depth) {
  SEMMAP_ASSIGN_OR_RETURN(TrackingResult tracked,
                          tracker_->Track(frame.colour, depth, frame.stamp_ns));
  FrameEstimate estimate;
  estimate.T_world_camera = tracked.T_world_camera;
  estimate.is_keyframe = tracked.is_keyframe;
  estimate.new_segment = tracked.new_segment;
  estimate.information = tracked.information;
  estimate.keyframe_features = std::move(tracked.keyframe_features);
  if (tracked.state == TrackingState::kLost) {
    if (T_world_last_ && step.T_prev_cur) {
      // Features failed (blur, a bare wall): the network's motion carries the pose on until
      // the tracker finds its map again.
      estimate.T_world_camera = *T_world_last_ * *step.T_prev_cur;
    } else {
      estimate.lost = true;
    }
  }
  return estimate;
}

void MonoProcessor::ApplyCorrection(const Eigen::Isometry3d& T_corrected_world) {
  if (tracker_) tracker_->ApplyCorrection(T_corrected_world);
  keyframes_.ApplyCorrection(T_corrected_world);
  if (T_world_last_) T_world_last_ = T_corrected_world * *T_world_last_;
}

}  // namespace semmap
