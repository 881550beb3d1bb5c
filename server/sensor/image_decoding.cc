#include "server/sensor/image_decoding.h"

#include <cmath>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <string>
#include <vector>

namespace semmap {
namespace {

std::string SizeText(int w, int h) { return std::to_string(w) + "x" + std::to_string(h); }

Status CheckSize(const cv::Mat& m, int w, int h, const char* what) {
  if (m.cols != w || m.rows != h) {
    return InvalidArgumentError(std::string(what) + " is " + SizeText(m.cols, m.rows) +
                                " but the session camera is " + SizeText(w, h));
  }
  return OkStatus();
}

// Wraps raw pixel bytes (no copy) after checking width/height/step/data size agree.
StatusOr<cv::Mat> WrapRaw(const ImageMessage& image, int cv_type, int bytes_per_pixel,
                          const char* what) {
  const uint64_t min_step = static_cast<uint64_t>(image.width) * bytes_per_pixel;
  if (image.width == 0 || image.height == 0) {
    return InvalidArgumentError(std::string(what) + " has zero width or height");
  }
  const uint64_t step = image.step == 0 ? min_step : image.step;
  if (step < min_step) {
    return InvalidArgumentError(std::string(what) + " step " + std::to_string(step) +
                                " is less than width*bytes_per_pixel " + std::to_string(min_step));
  }
  const uint64_t expected = step * image.height;
  if (image.data.size() != expected) {
    return InvalidArgumentError(std::string(what) + " has " + std::to_string(image.data.size()) +
                                " bytes; " + image.encoding + " " +
                                SizeText(image.width, image.height) + " with step " +
                                std::to_string(step) + " needs " + std::to_string(expected));
  }
  return cv::Mat(static_cast<int>(image.height), static_cast<int>(image.width), cv_type,
                 const_cast<char*>(image.data.data()), static_cast<size_t>(step));
}

StatusOr<cv::Mat> DecodeCompressed(const ImageMessage& image, int flags, const char* what) {
  if (image.encoding != "png" && image.encoding != "jpeg" && image.encoding != "jpg") {
    return InvalidArgumentError(std::string(what) + " has unknown compressed format '" +
                                image.encoding + "' (expected png or jpeg)");
  }
  if (image.data.empty()) return InvalidArgumentError(std::string(what) + " has no data");
  cv::Mat decoded;
  try {
    const cv::Mat buf(1, static_cast<int>(image.data.size()), CV_8UC1,
                      const_cast<char*>(image.data.data()));
    decoded = cv::imdecode(buf, flags);
  } catch (const cv::Exception& e) {
    return InvalidArgumentError(std::string(what) + " could not be decoded: " + e.what());
  }
  if (decoded.empty()) {
    return InvalidArgumentError(std::string(what) + " could not be decoded as " + image.encoding);
  }
  return decoded;
}

}  // namespace

StatusOr<cv::Mat> DecodeColour(const ImageMessage& image, int w, int h) {
  cv::Mat out;
  if (image.kind == ImageMessage::Kind::kCompressed) {
    SEMMAP_ASSIGN_OR_RETURN(out, DecodeCompressed(image, cv::IMREAD_UNCHANGED, "colour image"));
    if (out.depth() != CV_8U) {
      return InvalidArgumentError("colour image must have 8-bit channels");
    }
    if (out.channels() == 4) {
      cv::cvtColor(out, out, cv::COLOR_BGRA2BGR);
    } else if (out.channels() != 1 && out.channels() != 3) {
      return InvalidArgumentError("colour image has " + std::to_string(out.channels()) +
                                  " channels");
    }
  } else if (image.encoding == "bgr8" || image.encoding == "rgb8") {
    SEMMAP_ASSIGN_OR_RETURN(cv::Mat wrapped, WrapRaw(image, CV_8UC3, 3, "colour image"));
    if (image.encoding == "rgb8") {
      cv::cvtColor(wrapped, out, cv::COLOR_RGB2BGR);
    } else {
      out = wrapped.clone();
    }
  } else if (image.encoding == "mono8") {
    SEMMAP_ASSIGN_OR_RETURN(cv::Mat wrapped, WrapRaw(image, CV_8UC1, 1, "colour image"));
    out = wrapped.clone();
  } else {
    return InvalidArgumentError("colour image has unknown encoding '" + image.encoding +
                                "' (expected rgb8, bgr8, mono8, or compressed png/jpeg)");
  }
  SEMMAP_RETURN_IF_ERROR(CheckSize(out, w, h, "colour image"));
  return out;
}

StatusOr<DecodedDepth> DecodeDepth(const DepthMessage& depth, int w, int h) {
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
    SEMMAP_ASSIGN_OR_RETURN(out.raw, DecodeCompressed(image, cv::IMREAD_ANYDEPTH, "depth image"));
    if (out.raw.type() != CV_16UC1) {
      return InvalidArgumentError("depth png must be single-channel 16-bit");
    }
    out.depth_scale = depth.depth_scale;
  } else if (image.encoding == "16UC1") {
    SEMMAP_ASSIGN_OR_RETURN(cv::Mat wrapped, WrapRaw(image, CV_16UC1, 2, "depth image"));
    out.raw = wrapped.clone();
    out.depth_scale = depth.depth_scale;
  } else if (metres) {
    SEMMAP_ASSIGN_OR_RETURN(cv::Mat wrapped, WrapRaw(image, CV_32FC1, 4, "depth image"));
    constexpr double kScale = 5000.0;  // 0.2 mm steps, up to 13 m
    cv::Mat cleaned = wrapped.clone();
    cv::patchNaNs(cleaned, 0.0);
    cleaned.convertTo(out.raw, CV_16UC1, kScale);  // saturates negatives to 0, far to 65535
    out.depth_scale = kScale;
  } else {
    return InvalidArgumentError("depth image has unknown encoding '" + image.encoding +
                                "' (expected 16UC1, 32FC1, or 16-bit png)");
  }
  SEMMAP_RETURN_IF_ERROR(CheckSize(out.raw, w, h, "depth image"));
  return out;
}

StatusOr<EncodedImage> EncodeColourForStorage(const ImageMessage& original, const cv::Mat& bgr) {
  EncodedImage out;
  if (original.kind == ImageMessage::Kind::kCompressed) {
    out.format = original.encoding == "png" ? "png" : "jpeg";
    out.bytes = original.data;
    return out;
  }
  std::vector<uint8_t> buf;
  if (!cv::imencode(".jpg", bgr, buf, {cv::IMWRITE_JPEG_QUALITY, 95})) {
    return InternalError("JPEG encoding of a keyframe failed");
  }
  out.format = "jpeg";
  out.bytes.assign(buf.begin(), buf.end());
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
  std::vector<uint8_t> buf;
  if (!cv::imencode(".png", depth.raw, buf, {cv::IMWRITE_PNG_COMPRESSION, 1})) {
    return InternalError("PNG encoding of a keyframe depth image failed");
  }
  out.bytes.assign(buf.begin(), buf.end());
  return out;
}

}  // namespace semmap
