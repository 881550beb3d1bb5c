#include "core/sensor/image_decoding.h"

#include <cmath>
#include <new>
#include <opencv2/imgproc.hpp>
#include <string>
#include <utility>
#include <vector>

#include "common/checked_math.h"
#include "core/sensor/compressed_image.h"
#include "core/sensor/image_encoding.h"

namespace semmap {
namespace {

std::string SizeText(uint64_t w, uint64_t h) { return std::to_string(w) + "x" + std::to_string(h); }

// An image must have the session camera's size; checked before anything else is looked at.
Status CheckCameraSize(uint64_t width, uint64_t height, int w, int h, const char* what) {
  if (width != static_cast<uint64_t>(w) || height != static_cast<uint64_t>(h)) {
    return InvalidArgumentError(std::string(what) + " is " + SizeText(width, height) +
                                " but the session camera is " + SizeText(w, h));
  }
  return OkStatus();
}

// Wraps raw pixel bytes (no copy) after checking that the size is the camera's (w x h) and that
// step and data size agree. The step and data sizes are computed in checked arithmetic: the
// numbers are the client's.
StatusOr<cv::Mat> WrapRaw(const ImageMessage& image, int w, int h, int cv_type,
                          uint64_t bytes_per_pixel, const char* what) {
  SEMMAP_RETURN_IF_ERROR(CheckCameraSize(image.width, image.height, w, h, what));
  if (image.width == 0 || image.height == 0) {
    return InvalidArgumentError(std::string(what) + " has zero width or height");
  }
  const std::optional<uint64_t> min_step = CheckedMul(image.width, bytes_per_pixel);
  if (!min_step) {
    return InvalidArgumentError(std::string(what) + " size " + SizeText(image.width, image.height) +
                                " is too large");
  }
  const uint64_t step = image.step == 0 ? *min_step : image.step;
  if (step < *min_step) {
    return InvalidArgumentError(std::string(what) + " step " + std::to_string(step) +
                                " is less than width*bytes_per_pixel " + std::to_string(*min_step));
  }
  // Rows start on a whole sample (OpenCV refuses, by throwing, a step of e.g. 13 for 16UC1).
  const uint64_t sample_bytes = CV_ELEM_SIZE1(cv_type);
  if (step % sample_bytes != 0) {
    return InvalidArgumentError(std::string(what) + " step " + std::to_string(step) +
                                " is not a multiple of its " + std::to_string(sample_bytes) +
                                "-byte samples (" + image.encoding + ")");
  }
  const std::optional<uint64_t> expected = CheckedMul(step, image.height);
  if (!expected || image.data.size() != *expected) {
    return InvalidArgumentError(
        std::string(what) + " has " + std::to_string(image.data.size()) + " bytes; " +
        image.encoding + " " + SizeText(image.width, image.height) + " with step " +
        std::to_string(step) + " needs " +
        (expected ? std::to_string(*expected) : std::string("more than 2^64")));
  }
  return cv::Mat(h, w, cv_type, const_cast<char*>(image.data.data()), static_cast<size_t>(step));
}

// Reads the header, checks the declared format and the size against the camera's, and only
// then decodes (a small file cannot make the server allocate a huge image).
StatusOr<cv::Mat> DecodeCompressed(const ImageMessage& image, DecodeTarget target, int w, int h,
                                   const char* what) {
  if (image.encoding != "png" && image.encoding != "jpeg" && image.encoding != "jpg") {
    return InvalidArgumentError(std::string(what) + " has unknown compressed format '" +
                                image.encoding + "' (expected png or jpeg)");
  }
  if (image.data.empty()) return InvalidArgumentError(std::string(what) + " has no data");
  StatusOr<CompressedImageInfo> info = ProbeCompressedImage(image.data);
  if (!info.ok()) {
    return Status(info.status().code(),
                  std::string(what) + " could not be decoded: it " + info.status().message());
  }
  const bool declared_png = image.encoding == "png";
  if (declared_png != (info->format == CompressedFormat::kPng)) {
    return InvalidArgumentError(std::string(what) + " is declared " + image.encoding +
                                " but its bytes are a " +
                                std::string(CompressedFormatName(info->format)));
  }
  SEMMAP_RETURN_IF_ERROR(CheckCameraSize(info->width, info->height, w, h, what));
  // The decoder allocates exactly the header's size, so what it returns is the camera's.
  StatusOr<cv::Mat> decoded = DecodeCompressedImage(image.data, *info, target);
  if (!decoded.ok()) {
    return Status(decoded.status().code(),
                  std::string(what) + " could not be decoded: " + decoded.status().message());
  }
  return decoded;
}

// OpenCV reports what it refuses by throwing; client bytes must never end the process, so the
// public entry points turn what slipped past the checks above into a Status.
template <typename Decode>
auto GuardOpenCv(const char* what, Decode decode) -> decltype(decode()) {
  try {
    return decode();
  } catch (const cv::Exception& e) {
    return InvalidArgumentError(std::string(what) + " could not be decoded: " + e.msg);
  } catch (const std::bad_alloc&) {
    return ResourceExhaustedError(std::string("out of memory decoding the ") + what);
  }
}

StatusOr<cv::Mat> DecodeColourUnguarded(const ImageMessage& image, int w, int h) {
  cv::Mat out;
  if (image.kind == ImageMessage::Kind::kCompressed) {
    SEMMAP_ASSIGN_OR_RETURN(out,
                            DecodeCompressed(image, DecodeTarget::kColour, w, h, "colour image"));
  } else if (image.encoding == "bgr8" || image.encoding == "rgb8") {
    SEMMAP_ASSIGN_OR_RETURN(cv::Mat wrapped, WrapRaw(image, w, h, CV_8UC3, 3, "colour image"));
    if (image.encoding == "rgb8") {
      cv::cvtColor(wrapped, out, cv::COLOR_RGB2BGR);
    } else {
      out = wrapped.clone();
    }
  } else if (image.encoding == "mono8") {
    SEMMAP_ASSIGN_OR_RETURN(cv::Mat wrapped, WrapRaw(image, w, h, CV_8UC1, 1, "colour image"));
    out = wrapped.clone();
  } else {
    return InvalidArgumentError("colour image has unknown encoding '" + image.encoding +
                                "' (expected rgb8, bgr8, mono8, or compressed png/jpeg)");
  }
  return out;
}

StatusOr<DecodedDepth> DecodeDepthUnguarded(const DepthMessage& depth, int w, int h) {
  const ImageMessage& image = depth.image;
  DecodedDepth out;
  const bool metres = image.kind == ImageMessage::Kind::kRaw && image.encoding == "32FC1";
  if (!metres && !(std::isfinite(depth.depth_scale) && depth.depth_scale > 0)) {
    return InvalidArgumentError("depth_scale must be a positive number of units per metre (got " +
                                std::to_string(depth.depth_scale) + ")");
  }
  if (image.kind == ImageMessage::Kind::kCompressed) {
    if (image.encoding != "png") {
      return InvalidArgumentError("compressed depth must be 16-bit png (got '" + image.encoding +
                                  "')");
    }
    SEMMAP_ASSIGN_OR_RETURN(out.raw,
                            DecodeCompressed(image, DecodeTarget::kDepth16, w, h, "depth image"));
    out.depth_scale = depth.depth_scale;
  } else if (image.encoding == "16UC1") {
    SEMMAP_ASSIGN_OR_RETURN(cv::Mat wrapped, WrapRaw(image, w, h, CV_16UC1, 2, "depth image"));
    out.raw = wrapped.clone();
    out.depth_scale = depth.depth_scale;
  } else if (metres) {
    SEMMAP_ASSIGN_OR_RETURN(cv::Mat wrapped, WrapRaw(image, w, h, CV_32FC1, 4, "depth image"));
    constexpr double kScale = 5000.0;  // 0.2 mm steps, up to 13 m
    cv::Mat cleaned = wrapped.clone();
    cv::patchNaNs(cleaned, 0.0);
    cleaned.convertTo(out.raw, CV_16UC1, kScale);  // saturates negatives to 0, far to 65535
    out.depth_scale = kScale;
  } else {
    return InvalidArgumentError("depth image has unknown encoding '" + image.encoding +
                                "' (expected 16UC1, 32FC1, or 16-bit png)");
  }
  return out;
}

}  // namespace

StatusOr<cv::Mat> DecodeColour(const ImageMessage& image, int w, int h) {
  return GuardOpenCv("colour image", [&] { return DecodeColourUnguarded(image, w, h); });
}

StatusOr<DecodedDepth> DecodeDepth(const DepthMessage& depth, int w, int h) {
  return GuardOpenCv("depth image", [&] { return DecodeDepthUnguarded(depth, w, h); });
}

StatusOr<EncodedImage> EncodeColourForStorage(const ImageMessage& original, const cv::Mat& bgr) {
  EncodedImage out;
  if (original.kind == ImageMessage::Kind::kCompressed) {
    out.format = original.encoding == "png" ? "png" : "jpeg";
    out.bytes = original.data;
    return out;
  }
  StatusOr<std::string> jpeg = EncodeJpeg(bgr, 95);
  if (!jpeg.ok()) return jpeg.status().WithContext("keyframe colour image");
  out.format = "jpeg";
  out.bytes = std::move(jpeg).value();
  return out;
}

StatusOr<EncodedImage> EncodeDepthForStorage(const DepthMessage& original,
                                             const DecodedDepth& depth) {
  EncodedImage out;
  out.format = "png";
  if (original.image.kind == ImageMessage::Kind::kCompressed) {
    out.bytes = original.image.data;
    return out;
  }
  StatusOr<std::string> png = EncodePng(depth.raw, 1);
  if (!png.ok()) return png.status().WithContext("keyframe depth image");
  out.bytes = std::move(png).value();
  return out;
}

}  // namespace semmap
