// Image decoding on the ingest path: what one 640x480 frame costs the server before tracking.
// Uses the committed demo sample so it runs on any checkout.
#include <benchmark/benchmark.h>

#include <fstream>
#include <opencv2/imgcodecs.hpp>
#include <sstream>
#include <vector>

#include "core/sensor/image_decoding.h"
#include "core/sensor/internal/png_decoders.h"

namespace semmap {
namespace {

const std::string kSample = std::string(SEMMAP_SOURCE_DIR) + "/data/samples/tum_fr3_teddy_80/";

std::string ReadFile(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream buffer;
  buffer << in.rdbuf();
  return buffer.str();
}

ImageMessage Compressed(const std::string& format, const std::string& path) {
  ImageMessage image;
  image.kind = ImageMessage::Kind::kCompressed;
  image.encoding = format;
  image.data = ReadFile(path);
  return image;
}

// The sample's first colour frame, decoded once: the source of the PNG and raw variants.
cv::Mat SampleBgr() {
  return *DecodeColour(Compressed("jpeg", kSample + "rgb/1341841873.273798.jpg"), 640, 480);
}

void DecodeColourLoop(benchmark::State& state, const ImageMessage& image) {
  for (auto _ : state) {
    auto decoded = DecodeColour(image, 640, 480);
    if (!decoded.ok()) state.SkipWithError(decoded.status().ToString().c_str());
    benchmark::DoNotOptimize(decoded);
  }
  state.SetBytesProcessed(state.iterations() * image.data.size());
}

void BM_DecodeColourJpeg(benchmark::State& state) {
  DecodeColourLoop(state, Compressed("jpeg", kSample + "rgb/1341841873.273798.jpg"));
}
BENCHMARK(BM_DecodeColourJpeg)->Unit(benchmark::kMillisecond);

void BM_DecodeColourPng(benchmark::State& state) {
  // Re-encode the sample as PNG: TUM publishes colour as PNG.
  const cv::Mat bgr = SampleBgr();
  ImageMessage png;
  png.kind = ImageMessage::Kind::kCompressed;
  png.encoding = "png";
  {
    std::vector<uint8_t> buf;
    cv::imencode(".png", bgr, buf);
    png.data.assign(buf.begin(), buf.end());
  }
  DecodeColourLoop(state, png);
}
BENCHMARK(BM_DecodeColourPng)->Unit(benchmark::kMillisecond);

void BM_DecodeColourRawRgb(benchmark::State& state) {
  const cv::Mat bgr = SampleBgr();
  ImageMessage raw;
  raw.kind = ImageMessage::Kind::kRaw;
  raw.encoding = "rgb8";
  raw.width = 640;
  raw.height = 480;
  raw.data.assign(reinterpret_cast<const char*>(bgr.data), bgr.total() * 3);
  DecodeColourLoop(state, raw);
}
BENCHMARK(BM_DecodeColourRawRgb)->Unit(benchmark::kMillisecond);

void BM_DecodeDepthPng(benchmark::State& state) {
  DepthMessage depth;
  depth.image = Compressed("png", kSample + "depth/1341841873.273820.png");
  depth.depth_scale = 5000;
  for (auto _ : state) {
    auto decoded = DecodeDepth(depth, 640, 480);
    if (!decoded.ok()) state.SkipWithError(decoded.status().ToString().c_str());
    benchmark::DoNotOptimize(decoded);
  }
  state.SetBytesProcessed(state.iterations() * depth.image.data.size());
}
BENCHMARK(BM_DecodeDepthPng)->Unit(benchmark::kMillisecond);

// A real TUM colour (8-bit RGB) and depth (16-bit grey) PNG through both PNG decoders in the
// same run: the fast path (libdeflate + our row filters) against libpng. Skipped without
// ../shared/data.
const std::string kTeddy = std::string(SEMMAP_SHARED_DATA_DIR) + "/tum_fr3_teddy_200/";

template <bool kFast>
void PngDecoderLoop(benchmark::State& state, const std::string& path, DecodeTarget target) {
  const std::string bytes = ReadFile(path);
  StatusOr<CompressedImageInfo> info = ProbeCompressedImage(bytes);
  if (!info.ok()) {
    state.SkipWithError((path + " absent or unreadable (needs ../shared/data)").c_str());
    return;
  }
  for (auto _ : state) {
    if constexpr (kFast) {
      std::optional<cv::Mat> decoded = sensor_internal::DecodePngFast(bytes, *info, target);
      if (!decoded) state.SkipWithError("the fast path did not take the image");
      benchmark::DoNotOptimize(decoded);
    } else {
      StatusOr<cv::Mat> decoded = sensor_internal::DecodePngWithLibpng(bytes, *info, target);
      if (!decoded.ok()) state.SkipWithError(decoded.status().ToString().c_str());
      benchmark::DoNotOptimize(decoded);
    }
  }
  state.SetBytesProcessed(state.iterations() * static_cast<int64_t>(bytes.size()));
}
void BM_TeddyColourPngLibpng(benchmark::State& state) {
  PngDecoderLoop<false>(state, kTeddy + "rgb/1341841873.273798.png", DecodeTarget::kColour);
}
void BM_TeddyColourPngFast(benchmark::State& state) {
  PngDecoderLoop<true>(state, kTeddy + "rgb/1341841873.273798.png", DecodeTarget::kColour);
}
void BM_TeddyDepthPngLibpng(benchmark::State& state) {
  PngDecoderLoop<false>(state, kTeddy + "depth/1341841873.273820.png", DecodeTarget::kDepth16);
}
void BM_TeddyDepthPngFast(benchmark::State& state) {
  PngDecoderLoop<true>(state, kTeddy + "depth/1341841873.273820.png", DecodeTarget::kDepth16);
}
BENCHMARK(BM_TeddyColourPngLibpng)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_TeddyColourPngFast)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_TeddyDepthPngLibpng)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_TeddyDepthPngFast)->Unit(benchmark::kMillisecond);

}  // namespace
}  // namespace semmap

BENCHMARK_MAIN();
