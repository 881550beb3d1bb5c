#include "core/odometry/mono_vo.h"

#include <array>
#include <string>
#include <utility>
#include <vector>

namespace semmap {
namespace {

cv::Mat Zeros(const std::vector<int>& shape) {
  return cv::Mat(static_cast<int>(shape.size()), shape.data(), CV_32F, cv::Scalar(0));
}

size_t Elements(const std::vector<int>& shape) {
  size_t n = 1;
  for (const int size : shape) n *= static_cast<size_t>(size);
  return n;
}

bool HasShape(const cv::Mat& m, const std::vector<int>& shape) {
  if (m.dims != static_cast<int>(shape.size())) return false;
  for (int i = 0; i < m.dims; ++i) {
    if (m.size[i] != shape[static_cast<size_t>(i)]) return false;
  }
  return true;
}

}  // namespace

MonoVoRunner::MonoVoRunner(const cv::dnn::Net& net, MonoVoModelInfo info)
    : net_(net), info_(std::move(info)) {
  output_names_ = {"pose6", "depth"};
  for (const MonoVoState& s : info_.state) output_names_.emplace_back(s.output);
}

void MonoVoRunner::Reset() { state_.clear(); }

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
  const bool first = state_.empty();
  std::vector<cv::Mat> outputs;
  try {
    net_.setInput(Blob(canonical_bgr), "image");
    for (size_t i = 0; i < info_.state.size(); ++i) {
      net_.setInput(first ? Zeros(info_.state[i].shape) : state_[i], info_.state[i].input);
    }
    net_.forward(outputs, output_names_);
  } catch (const cv::Exception& e) {
    return InternalError("VO network step failed: " + e.msg);
  } catch (const std::bad_alloc&) {
    return ResourceExhaustedError("out of memory in the VO network step");
  }
  const std::vector<int> depth_shape = {1, 1, info_.camera.height, info_.camera.width};
  bool shapes_ok = outputs.size() == output_names_.size() && outputs[0].total() == 6 &&
                   HasShape(outputs[1], depth_shape);
  for (size_t i = 0; shapes_ok && i < info_.state.size(); ++i) {
    shapes_ok = outputs[2 + i].total() == Elements(info_.state[i].shape);
  }
  if (!shapes_ok) return InternalError("VO network outputs do not have the sidecar's shapes");
  MonoVoStep step;
  step.depth =
      cv::Mat(info_.camera.height, info_.camera.width, CV_32F, outputs[1].ptr<float>()).clone();
  if (!first) {
    std::array<float, 6> pose6{};
    const auto* p = outputs[0].ptr<float>();
    std::copy(p, p + 6, pose6.begin());
    SEMMAP_ASSIGN_OR_RETURN(step.T_prev_cur, PoseFromPose6(pose6));
  }
  // The sidecar's protocol: a first frame's LSTM state is thrown away (zeros carried instead).
  state_.resize(info_.state.size());
  for (size_t i = 0; i < info_.state.size(); ++i) {
    const MonoVoState& s = info_.state[i];
    state_[i] =
        first && s.discard_first ? Zeros(s.shape) : outputs[2 + i].reshape(1, s.shape).clone();
  }
  return step;
}

}  // namespace semmap
