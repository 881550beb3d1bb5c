#include "core/odometry/mono_vo_model.h"

#include <cmath>
#include <fstream>
#include <nlohmann/json.hpp>
#include <opencv2/dnn.hpp>
#include <set>
#include <sstream>
#include <utility>

#include "common/sha256.h"
#include "core/odometry/mono_vo.h"

namespace semmap {
namespace {

using Json = nlohmann::json;

// The value at a path of object keys, or nullptr (never throws).
const Json* At(const Json& root, std::initializer_list<const char*> path) {
  const Json* node = &root;
  for (const char* key : path) {
    if (!node->is_object()) return nullptr;
    const auto it = node->find(key);
    if (it == node->end()) return nullptr;
    node = &*it;
  }
  return node;
}

std::string PathName(std::initializer_list<const char*> path) {
  std::string name;
  for (const char* key : path) name += (name.empty() ? "" : ".") + std::string(key);
  return name;
}

StatusOr<double> Number(const Json& root, std::initializer_list<const char*> path) {
  const Json* node = At(root, path);
  if (node == nullptr || !node->is_number()) {
    return InvalidArgumentError("VO model sidecar: " + PathName(path) + " must be a number");
  }
  const double value = node->get<double>();
  if (!std::isfinite(value)) {
    return InvalidArgumentError("VO model sidecar: " + PathName(path) + " is not finite");
  }
  return value;
}

StatusOr<int> PositiveInt(const Json& root, std::initializer_list<const char*> path) {
  SEMMAP_ASSIGN_OR_RETURN(const double value, Number(root, path));
  if (value < 1 || value > 1 << 20 || value != std::floor(value)) {
    return InvalidArgumentError("VO model sidecar: " + PathName(path) +
                                " must be a positive integer");
  }
  return static_cast<int>(value);
}

StatusOr<std::vector<int>> Shape(const Json& root, std::initializer_list<const char*> path,
                                 size_t dims) {
  const Json* node = At(root, path);
  if (node == nullptr || !node->is_array() || node->size() != dims) {
    return InvalidArgumentError("VO model sidecar: " + PathName(path) + " must be a shape of " +
                                std::to_string(dims) + " sizes");
  }
  std::vector<int> shape;
  for (const Json& size : *node) {
    if (!size.is_number_integer() || size.get<int64_t>() < 1 || size.get<int64_t>() > 4096) {
      return InvalidArgumentError("VO model sidecar: " + PathName(path) +
                                  " sizes must be integers in 1..4096");
    }
    shape.push_back(static_cast<int>(size.get<int64_t>()));
  }
  if (shape[0] != 1) {
    return InvalidArgumentError("VO model sidecar: " + PathName(path) + " must have batch 1");
  }
  return shape;
}

// The sidecar's "state": [{"input", "output", "first_frame": "keep" | "discard"}], each input's
// shape under "inputs".
StatusOr<std::vector<MonoVoState>> StateList(const Json& root) {
  constexpr size_t kMaxState = 16;
  const Json* list = At(root, {"state"});
  if (list == nullptr || !list->is_array() || list->empty() || list->size() > kMaxState) {
    return InvalidArgumentError("VO model sidecar: state must list 1 to 16 recurrent inputs");
  }
  const Json* shapes = At(root, {"inputs"});
  std::vector<MonoVoState> state;
  std::set<std::string> names = {"image", "pose6", "depth"};
  for (const Json& entry : *list) {
    const Json* input = At(entry, {"input"});
    const Json* output = At(entry, {"output"});
    if (input == nullptr || output == nullptr || !input->is_string() || !output->is_string() ||
        input->get<std::string>().empty() || output->get<std::string>().empty() ||
        input->get<std::string>().size() > 64 || output->get<std::string>().size() > 64) {
      return InvalidArgumentError(
          "VO model sidecar: each state entry needs an input and an output name");
    }
    MonoVoState s;
    s.input = input->get<std::string>();
    s.output = output->get<std::string>();
    if (!names.insert(s.input).second || !names.insert(s.output).second) {
      return InvalidArgumentError("VO model sidecar: state name \"" + s.input + "\" or \"" +
                                  s.output + "\" is used twice");
    }
    const Json* first = At(entry, {"first_frame"});
    if (first != nullptr) {
      if (!first->is_string() ||
          (first->get<std::string>() != "keep" && first->get<std::string>() != "discard")) {
        return InvalidArgumentError(
            R"(VO model sidecar: state first_frame must be "keep" or "discard")");
      }
      s.discard_first = first->get<std::string>() == "discard";
    }
    if (shapes == nullptr || !shapes->is_object() || !shapes->contains(s.input)) {
      return InvalidArgumentError("VO model sidecar: inputs." + s.input + " is missing");
    }
    const Json& shape = (*shapes)[s.input];
    const size_t dims = shape.is_array() ? shape.size() : 0;
    if (dims < 2 || dims > 4) {
      return InvalidArgumentError("VO model sidecar: inputs." + s.input +
                                  " must be a shape of 2 to 4 sizes");
    }
    SEMMAP_ASSIGN_OR_RETURN(s.shape, Shape(root, {"inputs", s.input.c_str()}, dims));
    state.push_back(std::move(s));
  }
  return state;
}

StatusOr<std::array<double, 3>> Triple(const Json& root, std::initializer_list<const char*> path) {
  const Json* node = At(root, path);
  if (node == nullptr || !node->is_array() || node->size() != 3) {
    return InvalidArgumentError("VO model sidecar: " + PathName(path) + " must hold 3 numbers");
  }
  std::array<double, 3> out{};
  for (size_t i = 0; i < 3; ++i) {
    if (!(*node)[i].is_number() || !std::isfinite((*node)[i].get<double>())) {
      return InvalidArgumentError("VO model sidecar: " + PathName(path) + " must hold 3 numbers");
    }
    out[i] = (*node)[i].get<double>();
  }
  return out;
}

StatusOr<std::string> ReadFile(const std::string& path, const char* what) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return NotFoundError(std::string(what) + " " + path + " cannot be opened");
  std::ostringstream bytes;
  bytes << in.rdbuf();
  if (in.bad()) return DataLossError(std::string(what) + " " + path + " cannot be read");
  return bytes.str();
}

std::string SidecarPath(const std::string& onnx_path) {
  const size_t dot = onnx_path.rfind('.');
  const size_t slash = onnx_path.rfind('/');
  const bool has_extension =
      dot != std::string::npos && (slash == std::string::npos || dot > slash);
  return (has_extension ? onnx_path.substr(0, dot) : onnx_path) + ".json";
}

}  // namespace

StatusOr<MonoVoModelInfo> ParseMonoVoSidecar(std::string_view text) {
  const Json root = Json::parse(text.begin(), text.end(), nullptr, /*allow_exceptions=*/false);
  if (root.is_discarded() || !root.is_object()) {
    return InvalidArgumentError("VO model sidecar is not a JSON object");
  }
  const Json* format = At(root, {"format"});
  if (format == nullptr || !format->is_string() || format->get<std::string>() != "semmap_vo/1") {
    return InvalidArgumentError("VO model sidecar: format must be \"semmap_vo/1\"");
  }
  MonoVoModelInfo info;
  SEMMAP_ASSIGN_OR_RETURN(info.camera.width, PositiveInt(root, {"input", "width"}));
  SEMMAP_ASSIGN_OR_RETURN(info.camera.height, PositiveInt(root, {"input", "height"}));
  SEMMAP_ASSIGN_OR_RETURN(info.camera.f, Number(root, {"input", "canonical_camera", "fx"}));
  SEMMAP_ASSIGN_OR_RETURN(const double fy, Number(root, {"input", "canonical_camera", "fy"}));
  if (fy != info.camera.f) {
    return InvalidArgumentError("VO model sidecar: the canonical camera must have fx == fy");
  }
  SEMMAP_ASSIGN_OR_RETURN(info.camera.cx, Number(root, {"input", "canonical_camera", "cx"}));
  SEMMAP_ASSIGN_OR_RETURN(info.camera.cy, Number(root, {"input", "canonical_camera", "cy"}));
  SEMMAP_RETURN_IF_ERROR(info.camera.Validate().WithContext("VO model sidecar"));
  SEMMAP_ASSIGN_OR_RETURN(info.mean, Triple(root, {"input", "normalisation", "mean"}));
  SEMMAP_ASSIGN_OR_RETURN(info.stddev, Triple(root, {"input", "normalisation", "std"}));
  for (const double s : info.stddev) {
    if (!(s > 1e-6)) return InvalidArgumentError("VO model sidecar: std must be positive");
  }
  SEMMAP_ASSIGN_OR_RETURN(const std::vector<int> image, Shape(root, {"inputs", "image"}, 4));
  if (image[1] != 3 || image[2] != info.camera.height || image[3] != info.camera.width) {
    return InvalidArgumentError("VO model sidecar: inputs.image must be 1x3 at the input size");
  }
  SEMMAP_ASSIGN_OR_RETURN(info.state, StateList(root));
  const Json* sha = At(root, {"sha256"});
  if (sha == nullptr || !sha->is_string() || sha->get<std::string>().size() != 64) {
    return InvalidArgumentError("VO model sidecar: sha256 must be 64 hex digits");
  }
  info.sha256 = sha->get<std::string>();
  return info;
}

StatusOr<Eigen::Isometry3d> PoseFromPose6(const std::array<float, 6>& pose6) {
  for (const float v : pose6) {
    if (!std::isfinite(v)) return InvalidArgumentError("VO network gave a non-finite motion");
  }
  const Eigen::Vector3d t(pose6[0], pose6[1], pose6[2]);
  const Eigen::Vector3d r(pose6[3], pose6[4], pose6[5]);
  if (t.norm() > 10.0 || r.norm() > M_PI) {
    return InvalidArgumentError("VO network gave an implausible motion (" +
                                std::to_string(t.norm()) + " m, " + std::to_string(r.norm()) +
                                " rad in one frame)");
  }
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  const double angle = r.norm();
  if (angle > 1e-12) T.linear() = Eigen::AngleAxisd(angle, r / angle).toRotationMatrix();
  T.translation() = t;
  return T;
}

MonoVoModel::MonoVoModel(std::string path, std::string onnx, MonoVoModelInfo info)
    : path_(std::move(path)), onnx_(std::move(onnx)), info_(std::move(info)) {}

StatusOr<std::shared_ptr<const MonoVoModel>> MonoVoModel::Load(const std::string& onnx_path) {
  SEMMAP_ASSIGN_OR_RETURN(std::string onnx, ReadFile(onnx_path, "VO model"));
  const std::string sidecar_path = SidecarPath(onnx_path);
  SEMMAP_ASSIGN_OR_RETURN(const std::string sidecar, ReadFile(sidecar_path, "VO model sidecar"));
  StatusOr<MonoVoModelInfo> info = ParseMonoVoSidecar(sidecar);
  if (!info.ok()) return info.status().WithContext(sidecar_path);
  const std::string actual = ToHex(Sha256(onnx));
  if (actual != info->sha256) {
    return DataLossError("VO model " + onnx_path + " has sha256 " + actual + " but " +
                         sidecar_path + " says " + info->sha256 + " (damaged or mismatched)");
  }
  std::shared_ptr<const MonoVoModel> model(
      new MonoVoModel(onnx_path, std::move(onnx), std::move(info).value()));
  // Build it and run a first frame once: a graph OpenCV cannot run fails here, at start.
  SEMMAP_ASSIGN_OR_RETURN(std::unique_ptr<MonoVoRunner> runner, model->NewRunner());
  const CanonicalCamera& camera = model->info().camera;
  StatusOr<MonoVoStep> step = runner->Step(cv::Mat::zeros(camera.height, camera.width, CV_8UC3));
  if (step.ok()) step = runner->Step(cv::Mat::zeros(camera.height, camera.width, CV_8UC3));
  if (!step.ok()) {
    return DataLossError("VO model " + onnx_path + " does not run: " + step.status().message());
  }
  return model;
}

StatusOr<std::unique_ptr<MonoVoRunner>> MonoVoModel::NewRunner() const {
  try {
    cv::dnn::Net net = cv::dnn::readNetFromONNX(onnx_.data(), onnx_.size());
    if (net.empty()) return DataLossError("VO model " + path_ + " holds no network");
    net.setPreferableBackend(cv::dnn::DNN_BACKEND_OPENCV);
    net.setPreferableTarget(cv::dnn::DNN_TARGET_CPU);
    return std::make_unique<MonoVoRunner>(net, info_);
  } catch (const cv::Exception& e) {
    return DataLossError("VO model " + path_ + " cannot be imported by OpenCV: " + e.msg);
  } catch (const std::bad_alloc&) {
    return ResourceExhaustedError("out of memory building the VO network");
  }
}

}  // namespace semmap
