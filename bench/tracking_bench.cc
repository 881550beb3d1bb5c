// RGB-D tracking front end (core/odometry) on synthetic 640x480 frames of the default room
// (circle trajectory, 120 frames per lap). Each benchmark reports the p50 of its per-frame
// times as the counter p50_ms (Google Benchmark's own figure is the mean):
//   BM_Extract      ORB detection + grid bucketing + descriptors + depth lookup of one frame
//   BM_MatchPose    guided matching against the previous frame's features + PnP/refinement
//   BM_TrackFrame   RgbdTracker::Track on consecutive frames (extract + local-map matching +
//                   pose + keyframe/map bookkeeping), with extract/match/pose p50 from its own
//                   timings and the mean local-map size
//   BM_TrackTeddy   the same on the real TUM fr3/teddy frames (../shared/data; skipped with a
//                   message when absent): tracking's cost on a real Kinect sequence, alone on
//                   the machine (the server's figure also waits for the back end's threads)
//   BM_TrackSequence  the same on the folder $SEMMAP_TRACKING_BENCH_SEQUENCE names
#include <benchmark/benchmark.h>

#include <algorithm>
#include <chrono>
#include <cstdlib>
#include <memory>
#include <opencv2/imgcodecs.hpp>
#include <optional>
#include <string>
#include <vector>

#include "client/datasets/dataset.h"
#include "core/odometry/feature_extractor.h"
#include "core/odometry/feature_matcher.h"
#include "core/odometry/motion_estimator.h"
#include "core/odometry/rgbd_tracker.h"
#include "core/slam/keyframe_policy.h"
#include "tests/testing/synth/default_scene.h"
#include "tests/testing/synth/renderer.h"
#include "tests/testing/synth/sequence_writer.h"
#include "tests/testing/synth/trajectory.h"

namespace semmap {
namespace {

struct Sequence {
  CameraCalibration camera;
  std::vector<synth::RenderedFrame> frames;
  std::vector<StampedPose> poses;
};

// Rendered once per benchmark (not timed).
Sequence MakeSequence(int frames) {
  Sequence s;
  s.camera = synth::DefaultSyntheticCamera();
  StatusOr<synth::Scene> scene = synth::MakeDefaultRoomScene(1);
  if (!scene.ok()) std::abort();
  StatusOr<synth::Renderer> renderer = synth::Renderer::Create(*scene, s.camera);
  if (!renderer.ok()) std::abort();
  synth::TrajectoryOptions options;
  options.frames = 120;
  StatusOr<std::vector<StampedPose>> poses = synth::CircleTrajectory(scene->room, options);
  if (!poses.ok()) std::abort();
  s.poses.assign(poses->begin(), poses->begin() + frames);
  for (const StampedPose& p : s.poses) s.frames.push_back(renderer->Render(p.T_world_camera));
  return s;
}

double P50(std::vector<double> v) {
  if (v.empty()) return 0;
  std::nth_element(v.begin(), v.begin() + static_cast<long>(v.size() / 2), v.end());
  return v[v.size() / 2];
}

double Ms(std::chrono::steady_clock::time_point a, std::chrono::steady_clock::time_point b) {
  return std::chrono::duration<double, std::milli>(b - a).count();
}

void BM_Extract(benchmark::State& state) {
  const Sequence s = MakeSequence(30);
  StatusOr<FeatureExtractor> extractor = FeatureExtractor::Create({}, s.camera);
  if (!extractor.ok()) std::abort();
  std::vector<double> ms;
  size_t i = 0, keypoints = 0;
  for (auto _ : state) {
    const synth::RenderedFrame& f = s.frames[i++ % s.frames.size()];
    const auto t0 = std::chrono::steady_clock::now();
    StatusOr<FrameFeatures> features = extractor->Extract(f.bgr, f.depth, synth::kDepthScale);
    ms.push_back(Ms(t0, std::chrono::steady_clock::now()));
    if (!features.ok()) std::abort();
    keypoints += features->size();
    benchmark::DoNotOptimize(features);
  }
  state.counters["p50_ms"] = P50(ms);
  state.counters["keypoints"] = static_cast<double>(keypoints) / static_cast<double>(ms.size());
}
BENCHMARK(BM_Extract)->Unit(benchmark::kMillisecond);

void BM_MatchPose(benchmark::State& state) {
  const Sequence s = MakeSequence(30);
  StatusOr<FeatureExtractor> extractor = FeatureExtractor::Create({}, s.camera);
  if (!extractor.ok()) std::abort();
  std::vector<FrameFeatures> features;
  for (const synth::RenderedFrame& f : s.frames) {
    features.push_back(std::move(extractor->Extract(f.bgr, f.depth, synth::kDepthScale)).value());
  }
  const bool guided = state.range(0) != 0;
  std::vector<double> match_ms, pose_ms, total_ms;
  size_t i = 0;
  for (auto _ : state) {
    const size_t a = i++ % (features.size() - 1), b = a + 1;
    const FrameFeatures& ref = features[a];
    const FrameFeatures& cur = features[b];
    const Eigen::Isometry3d T_ref_cur =
        s.poses[a].T_world_camera.inverse() * s.poses[b].T_world_camera;
    const auto t0 = std::chrono::steady_clock::now();
    StatusOr<std::vector<cv::DMatch>> matches = [&]() -> StatusOr<std::vector<cv::DMatch>> {
      if (!guided) return MatchDescriptors(ref.descriptors, cur.descriptors, {});
      // Prediction: the true projection shifted by (3, -2) px, like a constant-velocity
      // guess's error.
      std::vector<std::optional<cv::Point2f>> predicted(ref.size());
      const Eigen::Isometry3d T_cur_ref = T_ref_cur.inverse();
      for (size_t k = 0; k < ref.size(); ++k) {
        if (!ref.has_depth[k]) continue;
        const Eigen::Vector3d p = T_cur_ref * ref.points_camera[k];
        if (p.z() <= 0) continue;
        predicted[k] =
            cv::Point2f(static_cast<float>(s.camera.fx * p.x() / p.z() + s.camera.cx + 3),
                        static_cast<float>(s.camera.fy * p.y() / p.z() + s.camera.cy - 2));
      }
      return MatchGuided(ref.descriptors, predicted, cur.descriptors, cur.keypoints, {});
    }();
    const auto t1 = std::chrono::steady_clock::now();
    if (!matches.ok()) std::abort();
    std::vector<Eigen::Vector3d> points;
    std::vector<cv::Point2f> pixels;
    for (const cv::DMatch& m : *matches) {
      if (!ref.has_depth[static_cast<size_t>(m.queryIdx)]) continue;
      points.push_back(ref.points_camera[static_cast<size_t>(m.queryIdx)]);
      pixels.push_back(cur.keypoints[static_cast<size_t>(m.trainIdx)].pt);
    }
    StatusOr<MotionEstimate> estimate = EstimateMotion(points, pixels, s.camera, {});
    const auto t2 = std::chrono::steady_clock::now();
    benchmark::DoNotOptimize(estimate);
    match_ms.push_back(Ms(t0, t1));
    pose_ms.push_back(Ms(t1, t2));
    total_ms.push_back(Ms(t0, t2));
  }
  state.counters["p50_ms"] = P50(total_ms);
  state.counters["match_p50_ms"] = P50(match_ms);
  state.counters["pose_p50_ms"] = P50(pose_ms);
}
BENCHMARK(BM_MatchPose)->Arg(0)->Arg(1)->ArgName("guided")->Unit(benchmark::kMillisecond);

void BM_TrackFrame(benchmark::State& state) {
  const Sequence s = MakeSequence(60);
  RgbdTrackerOptions options;
  options.camera = s.camera;
  std::vector<double> total, extract, match, pose;
  double map_points = 0;
  int64_t stamp = 0;
  size_t i = 0;
  StatusOr<RgbdTracker> tracker =
      RgbdTracker::Create(options, std::make_unique<KeyframePolicy>(KeyframePolicyOptions{}));
  if (!tracker.ok()) std::abort();
  for (auto _ : state) {
    if (i % s.frames.size() == 0) {  // restart at each lap of the stored frames (not timed)
      state.PauseTiming();
      tracker =
          RgbdTracker::Create(options, std::make_unique<KeyframePolicy>(KeyframePolicyOptions{}));
      state.ResumeTiming();
    }
    const synth::RenderedFrame& f = s.frames[i++ % s.frames.size()];
    DecodedDepth depth;
    depth.raw = f.depth;
    depth.depth_scale = synth::kDepthScale;
    StatusOr<TrackingResult> r = tracker->Track(f.bgr, depth, ++stamp);
    if (!r.ok()) std::abort();
    if (i % s.frames.size() == 1) continue;  // the first frame of a lap only extracts
    total.push_back(r->timings.total_ms);
    extract.push_back(r->timings.extract_ms);
    match.push_back(r->timings.match_ms);
    pose.push_back(r->timings.pose_ms);
    map_points += static_cast<double>(tracker->num_map_points());
  }
  state.counters["p50_ms"] = P50(total);
  state.counters["extract_p50_ms"] = P50(extract);
  state.counters["match_p50_ms"] = P50(match);
  state.counters["pose_p50_ms"] = P50(pose);
  state.counters["map_points"] = total.empty() ? 0 : map_points / static_cast<double>(total.size());
}
BENCHMARK(BM_TrackFrame)->Unit(benchmark::kMillisecond);

// RgbdTracker::Track over every frame of the TUM-layout sequence in `dir`, a new tracker per
// pass; `missing` says what to do when it cannot be read.
void TrackDataset(benchmark::State& state, const std::string& dir, const std::string& missing) {
  StatusOr<Dataset> dataset = OpenDataset(dir);
  if (!dataset.ok() || dataset->depth_scale <= 0) {
    state.SkipWithError(("no RGB-D sequence at " + dir + " (" + missing + ")").c_str());
    return;
  }
  struct Frame {
    cv::Mat bgr, depth;
    int64_t stamp_ns;
  };
  std::vector<Frame> frames;  // read once (not timed)
  for (const DatasetFrame& f : dataset->frames) {
    if (!f.depth_path) continue;
    frames.push_back({cv::imread(f.colour_path, cv::IMREAD_COLOR),
                      cv::imread(*f.depth_path, cv::IMREAD_ANYDEPTH), f.stamp_ns});
    if (frames.back().bgr.empty() || frames.back().depth.type() != CV_16UC1) {
      state.SkipWithError(("unreadable frame " + f.colour_path).c_str());
      return;
    }
  }
  RgbdTrackerOptions options;
  options.camera = dataset->camera;
  std::vector<double> total, extract, match, pose;
  size_t i = 0;
  int64_t lap_offset = 0;
  StatusOr<RgbdTracker> tracker =
      RgbdTracker::Create(options, std::make_unique<KeyframePolicy>(KeyframePolicyOptions{}));
  if (!tracker.ok()) std::abort();
  for (auto _ : state) {
    if (i > 0 && i % frames.size() == 0) {  // a new tracker for each pass (not timed)
      state.PauseTiming();
      tracker =
          RgbdTracker::Create(options, std::make_unique<KeyframePolicy>(KeyframePolicyOptions{}));
      lap_offset += frames.back().stamp_ns;
      state.ResumeTiming();
    }
    const Frame& f = frames[i++ % frames.size()];
    DecodedDepth depth;
    depth.raw = f.depth;
    depth.depth_scale = dataset->depth_scale;
    StatusOr<TrackingResult> r = tracker->Track(f.bgr, depth, lap_offset + f.stamp_ns);
    if (!r.ok()) std::abort();
    if (i % frames.size() == 1) continue;  // the first frame of a pass only extracts
    total.push_back(r->timings.total_ms);
    extract.push_back(r->timings.extract_ms);
    match.push_back(r->timings.match_ms);
    pose.push_back(r->timings.pose_ms);
  }
  state.counters["p50_ms"] = P50(total);
  state.counters["extract_p50_ms"] = P50(extract);
  state.counters["match_p50_ms"] = P50(match);
  state.counters["pose_p50_ms"] = P50(pose);
}

void BM_TrackTeddy(benchmark::State& state) {
  TrackDataset(state, std::string(SEMMAP_SHARED_DATA_DIR) + "/tum_fr3_teddy_200",
               "../shared/data/README.md");
}
BENCHMARK(BM_TrackTeddy)->Unit(benchmark::kMillisecond)->Iterations(200);

// Any TUM-layout sequence named by $SEMMAP_TRACKING_BENCH_SEQUENCE (e.g. one peer_bench or
// semmap-synth rendered, or 7-Scenes / ICL from ../shared/data/extra), for profiling tracking
// on data other than teddy; skipped when unset.
void BM_TrackSequence(benchmark::State& state) {
  const char* dir = std::getenv("SEMMAP_TRACKING_BENCH_SEQUENCE");
  if (dir == nullptr || *dir == '\0') {
    state.SkipWithError("set SEMMAP_TRACKING_BENCH_SEQUENCE to a TUM-layout RGB-D folder");
    return;
  }
  TrackDataset(state, dir, "$SEMMAP_TRACKING_BENCH_SEQUENCE");
}
BENCHMARK(BM_TrackSequence)->Unit(benchmark::kMillisecond)->Iterations(300);

}  // namespace
}  // namespace semmap

BENCHMARK_MAIN();
