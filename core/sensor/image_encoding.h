// PNG and JPEG encoding with libpng and libjpeg directly (the decoders' libraries), so the
// service needs no OpenCV image codecs: Debian's libopencv-imgcodecs pulls GDAL and about
// 300 MB of libraries into the runtime image for a few encodes.
#pragma once

#include <opencv2/core/mat.hpp>
#include <string>

#include "common/status.h"

namespace semmap {

// CV_8UC1 (grey), CV_8UC3 (BGR), CV_8UC4 (BGRA) or CV_16UC1 (e.g. depth) to PNG;
// `compression_level` 0 (fastest) .. 9 (smallest). INVALID_ARGUMENT for another type or an
// empty image.
StatusOr<std::string> EncodePng(const cv::Mat& image, int compression_level = 3);

// CV_8UC1 (grey) or CV_8UC3 (BGR) to baseline JPEG at `quality` 1..100.
StatusOr<std::string> EncodeJpeg(const cv::Mat& image, int quality = 95);

}  // namespace semmap
