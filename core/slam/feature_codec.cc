#include "core/slam/feature_codec.h"

#include <bit>
#include <cstdint>
#include <cstring>
#include <optional>
#include <type_traits>

#include "common/checked_math.h"

namespace semmap {
namespace {

constexpr char kMagic[4] = {'S', 'M', 'F', '1'};
// magic, u32 count, i32 descriptor columns, i32 descriptor type.
constexpr uint64_t kHeaderBytes = 16;
// Per keypoint: x y size angle response (f32), octave (i32), depth flag (u8), 3D point (3 f32).
constexpr uint64_t kKeypointBytes = 5 * sizeof(float) + sizeof(int32_t) + 1 + 3 * sizeof(float);

class Writer {
 public:
  template <typename T>
  void Put(T value) {
    static_assert(std::is_trivially_copyable_v<T>);
    out_.append(reinterpret_cast<const char*>(&value), sizeof(T));
  }
  void PutBytes(const void* data, size_t size) {
    out_.append(static_cast<const char*>(data), size);
  }
  std::string Take() { return std::move(out_); }

 private:
  std::string out_;
};

class Reader {
 public:
  explicit Reader(std::string_view in) : in_(in) {}
  template <typename T>
  bool Get(T& value) {
    return GetBytes(&value, sizeof(T));
  }
  bool GetBytes(void* data, size_t size) {
    if (in_.size() - pos_ < size) return false;
    std::memcpy(data, in_.data() + pos_, size);
    pos_ += size;
    return true;
  }
  bool done() const { return pos_ == in_.size(); }

 private:
  std::string_view in_;
  size_t pos_ = 0;
};

}  // namespace

std::string EncodeFeatures(const FrameFeatures& f) {
  static_assert(std::endian::native == std::endian::little, "the codec assumes little-endian");
  Writer w;
  w.PutBytes(kMagic, sizeof(kMagic));
  w.Put<uint32_t>(static_cast<uint32_t>(f.size()));
  w.Put<int32_t>(f.descriptors.empty() ? 0 : f.descriptors.cols);
  w.Put<int32_t>(f.descriptors.empty() ? CV_8U : f.descriptors.type());
  for (size_t i = 0; i < f.size(); ++i) {
    const cv::KeyPoint& k = f.keypoints[i];
    w.Put<float>(k.pt.x);
    w.Put<float>(k.pt.y);
    w.Put<float>(k.size);
    w.Put<float>(k.angle);
    w.Put<float>(k.response);
    w.Put<int32_t>(k.octave);
    w.Put<uint8_t>(f.has_depth[i] ? 1 : 0);
    for (int a = 0; a < 3; ++a) w.Put<float>(static_cast<float>(f.points_camera[i][a]));
  }
  if (!f.descriptors.empty()) {
    const cv::Mat d = f.descriptors.isContinuous() ? f.descriptors : f.descriptors.clone();
    w.PutBytes(d.data, d.total() * d.elemSize());
  }
  return w.Take();
}

StatusOr<FrameFeatures> DecodeFeatures(std::string_view format, std::string_view bytes) {
  if (format != kFeatureCodecFormat) {
    return InvalidArgumentError("keyframe features have format '" + std::string(format) +
                                "', expected '" + std::string(kFeatureCodecFormat) + "'");
  }
  Reader r(bytes);
  char magic[4];
  uint32_t count = 0;
  int32_t cols = 0, type = 0;
  if (!r.GetBytes(magic, 4) || std::memcmp(magic, kMagic, 4) != 0 || !r.Get(count) ||
      !r.Get(cols) || !r.Get(type)) {
    return DataLossError("keyframe features: bad header");
  }
  if ((type != CV_8U && type != CV_32F) || cols < 0 || cols > 4096 || count > 1'000'000) {
    return DataLossError("keyframe features: implausible header");
  }
  // The whole size the header announces, checked before anything is allocated: a 16-byte
  // header must not make the decoder reserve room for a million keypoints.
  const std::optional<uint64_t> keypoints = CheckedMul(count, kKeypointBytes);
  const std::optional<uint64_t> keypoints_end =
      keypoints ? CheckedAdd(kHeaderBytes, *keypoints) : std::nullopt;
  const std::optional<uint64_t> descriptors = CheckedProduct(
      {count, count > 0 ? static_cast<uint64_t>(cols) : 0, type == CV_32F ? sizeof(float) : 1});
  const std::optional<uint64_t> total =
      keypoints_end && descriptors ? CheckedAdd(*keypoints_end, *descriptors) : std::nullopt;
  if (!keypoints_end || *keypoints_end > bytes.size()) {
    return DataLossError("keyframe features: truncated at keypoint " +
                         std::to_string((bytes.size() - kHeaderBytes) / kKeypointBytes));
  }
  if (!total || *total > bytes.size()) {
    return DataLossError("keyframe features: truncated descriptors");
  }
  if (*total < bytes.size()) return DataLossError("keyframe features: trailing bytes");
  FrameFeatures f;
  f.keypoints.resize(count);
  f.has_depth.resize(count);
  f.points_camera.resize(count);
  for (uint32_t i = 0; i < count; ++i) {
    cv::KeyPoint& k = f.keypoints[i];
    uint8_t depth = 0;
    float p[3];
    if (!r.Get(k.pt.x) || !r.Get(k.pt.y) || !r.Get(k.size) || !r.Get(k.angle) ||
        !r.Get(k.response) || !r.Get(k.octave) || !r.Get(depth) || !r.Get(p[0]) || !r.Get(p[1]) ||
        !r.Get(p[2])) {
      return DataLossError("keyframe features: truncated at keypoint " + std::to_string(i));
    }
    f.has_depth[i] = depth != 0;
    f.points_camera[i] = Eigen::Vector3d(p[0], p[1], p[2]);
  }
  if (count > 0 && cols > 0) {
    f.descriptors.create(static_cast<int>(count), cols, type);
    if (!r.GetBytes(f.descriptors.data, f.descriptors.total() * f.descriptors.elemSize())) {
      return DataLossError("keyframe features: truncated descriptors");
    }
  }
  if (!r.done()) return DataLossError("keyframe features: trailing bytes");
  return f;
}

}  // namespace semmap
