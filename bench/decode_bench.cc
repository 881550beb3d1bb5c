// Image decoding on the ingest path: what one 640x480 frame costs the server before tracking.
// Uses the committed demo sample so it runs on any checkout.
#include <benchmark/benchmark.h>

#include <fstream>
#include <opencv2/imgcodecs.hpp>
#include <sstream>
#include <vector>

#include "core/sensor/image_decoding.h"

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

}  // namespace
}  // namespace semmap

BENCHMARK_MAIN();
