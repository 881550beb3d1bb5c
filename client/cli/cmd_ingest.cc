// semmap ingest DIR: streams a dataset into semmapd, frame by frame, and reports what was stored.
#include <filesystem>
#include <iomanip>
#include <iostream>
#include <map>
#include <mutex>
#include <thread>

#include "client/cli/commands.h"
#include "client/cli/progress_bar.h"
#include "client/datasets/dataset.h"
#include "client/datasets/pose_lookup.h"
#include "client/datasets/trajectory_io.h"
#include "client/lib/wire_frame.h"
#include "server/serialization/conversions.h"

namespace semmap::cli {
namespace {

constexpr char kUsage[] =
    "usage: semmap ingest DIR [options]\n"
    "  Streams a dataset (TUM RGB-D layout: rgb.txt, depth.txt, camera.yaml; or KITTI odometry\n"
    "  layout: image_0/, calib.txt, times.txt) into a map. Without --poses the session mode is\n"
    "  RGBD (MONO when the dataset has no depth or with --mono).\n";

struct IngestArgs {
  std::string dir;
  std::string map = "default";
  std::string session;
  bool mono = false;
  std::string poses_path;
  std::string trajectory_out;
  std::string online_trajectory_out;
  double rate_hz = 0;  // 0: as fast as the server takes frames
  double keyframe_min_motion = 0;
};

// --poses accepts a path, or a file name inside the dataset directory ("groundtruth.txt").
std::string ResolvePosesPath(const std::string& dir, const std::string& path) {
  namespace fs = std::filesystem;
  if (fs::exists(path)) return path;
  const fs::path inside = fs::path(dir) / path;
  return fs::exists(inside) ? inside.string() : path;
}

}  // namespace

int RunIngest(CliContext context, int argc, const char* const* argv) {
  ArgParser parser;
  AddCommonFlags(parser);
  parser.AddFlag("map", "M", "map to add the session to (created if new; default 'default')");
  parser.AddFlag("session", "S", "session name (default: generated)");
  parser.AddSwitch("mono", "monocular session: send colour only");
  parser.AddFlag("poses", "TUM_FILE",
                 "known poses (T_world_camera) for every frame: KNOWN_POSES mode");
  parser.AddFlag("trajectory-out", "FILE",
                 "write the stored pose of every frame after the stream ended (TUM format; "
                 "includes the back end's loop-closure corrections)");
  parser.AddFlag("online-trajectory-out", "FILE",
                 "write the pose acknowledged for every frame while streaming (TUM format)");
  parser.AddFlag("rate", "HZ|max", "frames per second to send (default max)");
  parser.AddFlag("keyframe-min-motion", "M", "keyframe motion threshold for this session");
  const std::string usage = std::string(kUsage) + "\noptions:\n" + parser.Usage();
  if (Status parsed = parser.Parse(argc, argv, 0); !parsed.ok()) {
    return ReportUsage(parsed.message(), usage);
  }
  if (parser.Has("help")) {
    std::cout << usage;
    return kExitOk;
  }
  if (parser.positional().size() != 1) return ReportUsage("ingest needs one dataset DIR", usage);
  if (Status applied = ApplyCommonFlags(parser, &context); !applied.ok()) {
    return ReportUsage(applied.message(), usage);
  }

  IngestArgs args;
  args.dir = parser.positional()[0];
  args.map = parser.Get("map", args.map);
  args.session = parser.Get("session");
  args.mono = parser.Has("mono");
  args.trajectory_out = parser.Get("trajectory-out");
  args.online_trajectory_out = parser.Get("online-trajectory-out");
  if (parser.Has("poses")) args.poses_path = ResolvePosesPath(args.dir, parser.Get("poses"));
  if (const std::string rate = parser.Get("rate", "max"); rate != "max") {
    StatusOr<double> hz = parser.GetDouble("rate", 0);
    if (!hz.ok() || *hz <= 0) return ReportUsage("--rate must be a positive number or max", usage);
    args.rate_hz = *hz;
  }
  StatusOr<double> kf_motion = parser.GetDouble("keyframe-min-motion", 0);
  if (!kf_motion.ok()) return ReportUsage(kf_motion.status().message(), usage);
  args.keyframe_min_motion = *kf_motion;

  StatusOr<Dataset> dataset = OpenDataset(args.dir);
  if (!dataset.ok()) return ReportError(dataset.status());
  std::optional<PoseLookup> poses;
  if (!args.poses_path.empty()) {
    StatusOr<std::vector<StampedPose>> loaded = ReadTumTrajectory(args.poses_path);
    if (!loaded.ok()) return ReportError(loaded.status());
    poses.emplace(std::move(loaded).value());
  }
  const bool has_depth = dataset->depth_scale > 0 && !args.mono;

  v1::IngestStart start;
  start.set_map(args.map);
  start.set_session(args.session);
  start.set_mode(poses ? v1::SESSION_MODE_KNOWN_POSES
                       : (has_depth ? v1::SESSION_MODE_RGBD : v1::SESSION_MODE_MONO));
  ToProto(dataset->camera, start.mutable_camera());
  start.mutable_keyframes()->set_min_motion(args.keyframe_min_motion);

  // Poses the server reports, by seq, for --trajectory-out; when the last one came (the end of
  // streaming: what follows is the session's close, e.g. its final bundle adjustment).
  std::mutex acks_mutex;
  std::map<uint64_t, Eigen::Isometry3d> acked;
  std::chrono::steady_clock::time_point last_ack_at;
  MapClient client = MakeClient(context);
  StatusOr<std::unique_ptr<IngestStream>> stream =
      client.Ingest(start, [&](const v1::FrameAck& ack) {
        std::lock_guard lock(acks_mutex);
        acked[ack.seq()] = ToIsometry(FromProto(ack.t_world_camera()));
        last_ack_at = std::chrono::steady_clock::now();
      });
  if (!stream.ok()) return ReportError(stream.status());
  if (!context.json) {
    std::cerr << "ingesting " << dataset->frames.size() << " frames of " << args.dir
              << " into map '" << (*stream)->started().map() << "' session '"
              << (*stream)->started().session() << "'" << std::endl;
  }

  ProgressBar progress(dataset->frames.size(), !context.json);
  const auto t0 = std::chrono::steady_clock::now();
  uint64_t sent = 0, skipped_no_pose = 0;
  Status failure;
  for (const DatasetFrame& f : dataset->frames) {
    std::optional<Eigen::Isometry3d> T;
    if (poses && !(T = poses->At(f.stamp_ns))) {
      ++skipped_no_pose;
      continue;
    }
    StatusOr<v1::Frame> frame = MakeWireFrame(f, has_depth, dataset->depth_scale, T);
    if (!frame.ok()) {
      failure = frame.status();
      break;
    }
    if (args.rate_hz > 0) {
      std::this_thread::sleep_until(t0 + std::chrono::duration<double>(sent / args.rate_hz));
    }
    failure = (*stream)->Write(std::move(frame).value());
    if (!failure.ok()) break;
    ++sent;
    progress.Update(sent);
  }
  progress.Done();
  if (!failure.ok()) {
    (*stream)->Cancel();
    return ReportError(failure);
  }
  StatusOr<v1::IngestSummary> summary = (*stream)->Finish();
  if (!summary.ok()) return ReportError(summary.status());
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  double streaming_seconds = 0;
  {
    std::lock_guard lock(acks_mutex);
    if (!acked.empty()) streaming_seconds = std::chrono::duration<double>(last_ack_at - t0).count();
  }

  if (!args.online_trajectory_out.empty()) {
    std::vector<StampedPose> out;
    std::lock_guard lock(acks_mutex);
    for (const DatasetFrame& f : dataset->frames) {
      auto it = acked.find(f.seq);
      if (it != acked.end()) out.push_back({f.stamp_ns, it->second});
    }
    if (Status written = WriteTumTrajectory(args.online_trajectory_out, out); !written.ok()) {
      return ReportError(written);
    }
  }
  if (!args.trajectory_out.empty()) {
    StatusOr<std::vector<TrajectoryPose>> stored =
        client.GetTrajectory(summary->map(), summary->session(), /*keyframes_only=*/false);
    if (!stored.ok()) return ReportError(stored.status());
    std::vector<StampedPose> out;
    out.reserve(stored->size());
    for (const TrajectoryPose& p : *stored) out.push_back({p.stamp_ns, p.T_world_camera});
    if (Status written = WriteTumTrajectory(args.trajectory_out, out); !written.ok()) {
      return ReportError(written);
    }
  }

  const double fps = seconds > 0 ? sent / seconds : 0;
  const double streaming_fps = streaming_seconds > 0 ? sent / streaming_seconds : 0;
  if (context.json) {
    nlohmann::json out = {{"map", summary->map()},
                          {"session", summary->session()},
                          {"frames_sent", sent},
                          {"frames_stored", summary->frames()},
                          {"keyframes", summary->keyframes()},
                          {"lost_frames", summary->lost_frames()},
                          {"loop_closures", summary->loop_closures()},
                          {"new_segments", summary->new_segments()},
                          {"skipped_no_pose", skipped_no_pose},
                          {"seconds", seconds},
                          {"frames_per_second", fps},
                          {"streaming_seconds", streaming_seconds},
                          {"streaming_frames_per_second", streaming_fps}};
    out["durable_seq"] = summary->has_durable_seq() ? nlohmann::json(summary->durable_seq())
                                                    : nlohmann::json(nullptr);
    if (!args.trajectory_out.empty()) out["trajectory_out"] = args.trajectory_out;
    out["stages"] = nlohmann::json::object();
    for (const v1::StageLatency& stage : summary->stages()) {
      out["stages"][stage.name()] = {{"count", stage.count()},
                                     {"p50_ms", stage.p50_ms()},
                                     {"p95_ms", stage.p95_ms()},
                                     {"max_ms", stage.max_ms()},
                                     {"mean_ms", stage.mean_ms()}};
    }
    PrintJson(out);
  } else {
    std::cout << "stored " << summary->frames() << " frames (" << summary->keyframes()
              << " keyframes) in map '" << summary->map() << "' session '" << summary->session()
              << "' at " << std::fixed << std::setprecision(1) << fps << " frames/s";
    if (streaming_fps > 0) {
      std::cout << " (" << streaming_fps << " frames/s until the last frame's pose came back; "
                << std::setprecision(2) << seconds - streaming_seconds
                << " s more to close the session)";
    }
    std::cout << "\n";
    if (start.mode() == v1::SESSION_MODE_RGBD) {
      std::cout << "tracking lost on " << summary->lost_frames() << " frames ("
                << summary->new_segments() << " restarts after a loss); "
                << summary->loop_closures() << " loop closures\n";
    }
    if (skipped_no_pose > 0) {
      std::cout << "skipped " << skipped_no_pose
                << " frames with no pose in --poses within 0.2 s of their stamp\n";
    }
    if (!args.trajectory_out.empty()) {
      std::cout << "wrote the pose of every frame to " << args.trajectory_out << "\n";
    }
    std::cout << "server latency (ms)        p50      p95      max\n";
    for (const v1::StageLatency& stage : summary->stages()) {
      if (stage.count() == 0) continue;
      std::cout << "  " << std::left << std::setw(20) << stage.name() << std::right
                << std::setprecision(2) << std::setw(9) << stage.p50_ms() << std::setw(9)
                << stage.p95_ms() << std::setw(9) << stage.max_ms() << "\n";
    }
  }
  return kExitOk;
}

}  // namespace semmap::cli
