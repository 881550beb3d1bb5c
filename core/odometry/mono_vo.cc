#include "core/odometry/mono_vo.h"

#include <array>
#include <string>
#include <utility>
#include <vector>

namespace semmap {
namespace {

const std::vector<cv::String> kOutputs = {"pose6", "depth", "h_out", "c_out", "f2", "f3"};

cv::Mat Zeros(const std::vector<int>& shape) {
  return cv::Mat(static_cast<int>(shape.size()), shape.data(), CV_32F, cv::Scalar(0));
}

bool HasShape(const cv::Mat& m, const std::vector<int>& shape) {
  if (m.dims != static_cast<int>(shape.size())) return false;
  for (int i = 0; i < m.dims; ++i) {
    if (m.size[i] != shape[static_cast<size_t>(i)]) return false;
  }
  return true;
}

}  // namespace

MonoVoRunner::MonoVoRunner(cv::dnn::Net net, MonoVoModelInfo info)
    : net_(std::move(net)), info_(std::move(info)) {}

void MonoVoRunner::Reset() {
  prev_image_.release();
  prev_f2_.release();
  prev_f3_.release();
  h_.release();
  c_.release();
}

cv::Mat MonoVoRunner::Blob(const cv::Mat& canonical_bgr) const {
  // NCHW float, R, G, B planes: x = (rgb / 255 - mean) / std.
  const int h = info_.camera.height, w = info_.camera.width;
  const std::vector<int> shape = {1, 3, h, w};
  cv::Mat blob(4, shape.data(), CV_32F);
  for (int channel = 0; channel < 3; ++channel) {
    const int bgr_channel = 2 - channel;
    const auto scale = static_cast<float>(1.0 / (255.0 * info_.stddev[channel]));
    const auto offset = static_cast<float>(-info_.mean[channel] / info_.stddev[channel]);
    auto* plane = blob.ptr<float>(0, channel);
    for (int v = 0; v < h; ++v) {
      const auto* row = canonical_bgr.ptr<uint8_t>(v);
      for (int u = 0; u < w; ++u) plane[v * w + u] = row[3 * u + bgr_channel] * scale + offset;
    }
  }
  return blob;
}

StatusOr<MonoVoStep> MonoVoRunner::Step(const cv::Mat& canonical_bgr) {
  if (canonical_bgr.type() != CV_8UC3 || canonical_bgr.cols != info_.camera.width ||
      canonical_bgr.rows != info_.camera.height) {
    return InvalidArgumentError("VO step input must be BGR8 of the network's input size");
  }
  const bool first = prev_image_.empty();
  cv::Mat image = Blob(canonical_bgr);
  const std::vector<int> image_shape = {1, 3, info_.camera.height, info_.camera.width};
  const std::vector<int> state_shape = {1, info_.hidden};
  std::vector<cv::Mat> outputs;
  try {
    net_.setInput(image, "image");
    net_.setInput(first ? Zeros(image_shape) : prev_image_, "prev_image");
    net_.setInput(first ? Zeros(info_.f2_shape) : prev_f2_, "prev_f2");
    net_.setInput(first ? Zeros(info_.f3_shape) : prev_f3_, "prev_f3");
    net_.setInput(first ? Zeros(state_shape) : h_, "h");
    net_.setInput(first ? Zeros(state_shape) : c_, "c");
    net_.forward(outputs, kOutputs);
  } catch (const cv::Exception& e) {
    return InternalError("VO network step failed: " + e.msg);
  } catch (const std::bad_alloc&) {
    return ResourceExhaustedError("out of memory in the VO network step");
  }
  const std::vector<int> depth_shape = {1, 1, info_.camera.height, info_.camera.width};
  if (outputs.size() != kOutputs.size() || outputs[0].total() != 6 ||
      !HasShape(outputs[1], depth_shape) ||
      outputs[2].total() != static_cast<size_t>(info_.hidden) ||
      outputs[3].total() != static_cast<size_t>(info_.hidden) ||
      !HasShape(outputs[4], info_.f2_shape) || !HasShape(outputs[5], info_.f3_shape)) {
    return InternalError("VO network outputs do not have the sidecar's shapes");
  }
  MonoVoStep step;
  step.depth =
      cv::Mat(info_.camera.height, info_.camera.width, CV_32F, outputs[1].ptr<float>()).clone();
  if (!first) {
    std::array<float, 6> pose6{};
    const auto* p = outputs[0].ptr<float>();
    std::copy(p, p + 6, pose6.begin());
    SEMMAP_ASSIGN_OR_RETURN(step.T_prev_cur, PoseFromPose6(pose6));
  }
  // The protocol of training/semmap_vo/export.py: after the first frame h and c stay zero.
  prev_image_ = image;
  prev_f2_ = outputs[4].clone();
  prev_f3_ = outputs[5].clone();
  if (first) {
    h_ = Zeros(state_shape);
    c_ = Zeros(state_shape);
  } else {
    h_ = outputs[2].reshape(1, state_shape).clone();
    c_ = outputs[3].reshape(1, state_shape).clone();
  }
  return step;
}

}  // namespace semmap
