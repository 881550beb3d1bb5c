// semmapd: the semmap map server. Flags are validated and logged at start; SIGINT/SIGTERM are
// taken on a dedicated sigwait thread (never in a signal handler) and shut down cleanly.
#include <pthread.h>

#include <csignal>
#include <cstdio>
#include <iostream>

#include "common/arg_parser.h"
#include "common/logging.h"
#include "common/memory_trim.h"
#include "core/odometry/mono_vo_model.h"
#include "server/semmap_server.h"

namespace {

constexpr char kUsage[] =
    "usage: semmapd [options]\n"
    "\n"
    "The semmap map server: ingests camera streams over gRPC (semmap.v1.MapService), stores\n"
    "maps, sessions and keyframes in SQLite under --data-dir and answers map queries.\n"
    "SIGINT/SIGTERM: stop accepting, store what was received, commit, exit 0. SIGHUP: re-read\n"
    "--auth-tokens.\n"
    "\n"
    "options:\n";

semmap::Status ParseOptions(const semmap::ArgParser& args, semmap::ServerOptions* options) {
  options->listen = args.Get("listen", options->listen);
  SEMMAP_ASSIGN_OR_RETURN(options->log_level, semmap::ParseLogLevel(args.Get("log-level", "info")));
  options->data_dir = args.Get("data-dir", options->data_dir);
  options->tls_cert_file = args.Get("tls-cert", "");
  options->tls_key_file = args.Get("tls-key", "");
  options->tls_client_ca_file = args.Get("tls-client-ca", "");
  options->allow_insecure = args.Has("allow-insecure");
  options->auth_tokens_file = args.Get("auth-tokens", "");
  const std::string sync = args.Get("sqlite-sync", "full");
  if (sync != "full" && sync != "normal") {
    return semmap::InvalidArgumentError("--sqlite-sync must be full or normal");
  }
  options->sync_full = sync == "full";
  SEMMAP_ASSIGN_OR_RETURN(long long queue,
                          args.GetInt("queue-capacity", options->ingest.queue_capacity));
  if (queue < 1) return semmap::InvalidArgumentError("--queue-capacity must be >= 1");
  options->ingest.queue_capacity = static_cast<size_t>(queue);
  SEMMAP_ASSIGN_OR_RETURN(
      long long streams,
      args.GetInt("max-streams", static_cast<long long>(options->ingest.max_streams)));
  if (streams < 1) return semmap::InvalidArgumentError("--max-streams must be >= 1");
  options->ingest.max_streams = static_cast<size_t>(streams);
  SEMMAP_ASSIGN_OR_RETURN(options->ingest.max_frames_per_second,
                          args.GetDouble("max-session-fps", options->ingest.max_frames_per_second));
  SEMMAP_ASSIGN_OR_RETURN(
      long long open_maps,
      args.GetInt("max-open-maps", static_cast<long long>(options->ingest.max_open_maps)));
  SEMMAP_ASSIGN_OR_RETURN(
      long long idle_maps,
      args.GetInt("max-idle-maps", static_cast<long long>(options->ingest.max_idle_maps)));
  if (open_maps < 1 || idle_maps < 0) {
    return semmap::InvalidArgumentError("--max-open-maps must be >= 1 and --max-idle-maps >= 0");
  }
  options->ingest.max_open_maps = static_cast<size_t>(open_maps);
  options->ingest.max_idle_maps = static_cast<size_t>(idle_maps);
  semmap::CallLimits& calls = options->calls;
  SEMMAP_ASSIGN_OR_RETURN(long long workers,
                          args.GetInt("query-workers", static_cast<long long>(calls.workers)));
  SEMMAP_ASSIGN_OR_RETURN(long long worker_queue,
                          args.GetInt("query-queue", static_cast<long long>(calls.worker_queue)));
  SEMMAP_ASSIGN_OR_RETURN(
      long long exports,
      args.GetInt("max-pending-exports", static_cast<long long>(calls.max_pending_exports)));
  SEMMAP_ASSIGN_OR_RETURN(long long registrations,
                          args.GetInt("max-registrations-per-minute",
                                      static_cast<long long>(calls.max_registrations_per_minute)));
  if (workers < 1 || worker_queue < 1 || exports < 1 || registrations < 0) {
    return semmap::InvalidArgumentError(
        "--query-workers, --query-queue and --max-pending-exports must be >= 1, "
        "--max-registrations-per-minute >= 0");
  }
  calls.workers = static_cast<size_t>(workers);
  calls.worker_queue = static_cast<size_t>(worker_queue);
  calls.max_pending_exports = static_cast<size_t>(exports);
  calls.max_registrations_per_minute = static_cast<size_t>(registrations);
  SEMMAP_ASSIGN_OR_RETURN(options->ingest.idle_timeout_s,
                          args.GetDouble("stream-idle-timeout-s", options->ingest.idle_timeout_s));
  SEMMAP_ASSIGN_OR_RETURN(long long max_mb, args.GetInt("max-message-mb", 64));
  options->max_message_mb = static_cast<int>(max_mb);
  options->ingest.max_frame_bytes = static_cast<size_t>(std::max(1LL, max_mb)) << 20;
  SEMMAP_ASSIGN_OR_RETURN(
      options->ingest.keyframes.min_motion,
      args.GetDouble("keyframe-min-motion", options->ingest.keyframes.min_motion));
  SEMMAP_ASSIGN_OR_RETURN(
      options->ingest.keyframes.rotation_weight,
      args.GetDouble("keyframe-rotation-weight", options->ingest.keyframes.rotation_weight));
  SEMMAP_ASSIGN_OR_RETURN(
      options->ingest.keyframes.skip_mapped_views,
      args.GetOnOff("keyframe-skip-mapped", options->ingest.keyframes.skip_mapped_views));
  options->ingest.slam.follow_revisits = options->ingest.keyframes.skip_mapped_views;
  const std::string vocabulary = args.Get("vocabulary", "");
  if (vocabulary == "none") {
    options->vocabulary_path.clear();
  } else if (!vocabulary.empty()) {
    options->vocabulary_path = vocabulary;
    options->vocabulary_optional = false;
  }
  const std::string vo_model = args.Get("vo-model", "");
  if (vo_model == "none") {
    options->vo_model_path.clear();
  } else if (!vo_model.empty()) {
    options->vo_model_path = vo_model;  // still optional: a bad model refuses MONO, not the start
  }
  const std::string mono_vo = args.Get("mono-vo", "hybrid");
  if (mono_vo != "net" && mono_vo != "hybrid") {
    return semmap::InvalidArgumentError("--mono-vo must be net or hybrid");
  }
  options->ingest.mono_method =
      mono_vo == "net" ? semmap::MonoVoMethod::kNet : semmap::MonoVoMethod::kHybrid;
  SEMMAP_ASSIGN_OR_RETURN(options->ingest.slam.verifier.max_xi,
                          args.GetDouble("loop-max-xi", options->ingest.slam.verifier.max_xi));
  semmap::LocalBundleAdjustmentOptions& ba = options->ingest.slam.local_ba;
  SEMMAP_ASSIGN_OR_RETURN(ba.enabled, args.GetOnOff("local-ba", ba.enabled));
  SEMMAP_ASSIGN_OR_RETURN(ba.final_ba, args.GetOnOff("final-ba", ba.final_ba));
  semmap::PointFusionOptions& fusion = options->ingest.slam.point_fusion;
  const std::string fusion_mode = args.Get("point-fusion", "");  // empty: the defaults
  if (!fusion_mode.empty()) {
    if (fusion_mode != "off" && fusion_mode != "on" && fusion_mode != "all") {
      return semmap::InvalidArgumentError("--point-fusion must be off, on or all");
    }
    fusion.enabled = fusion_mode != "off";
    fusion.merge_established = fusion_mode == "all";
  }
  size_t& features_budget = options->ingest.slam.features_memory_bytes;
  SEMMAP_ASSIGN_OR_RETURN(
      long long features_mb,
      args.GetInt("slam-features-mb", static_cast<long long>(features_budget >> 20)));
  if (features_mb < 0 || features_mb > (1LL << 20)) {
    return semmap::InvalidArgumentError("--slam-features-mb must be in [0, 1048576]");
  }
  features_budget = static_cast<size_t>(features_mb) << 20;
  semmap::MapLayerOptions& map = options->ingest.layers;
  SEMMAP_ASSIGN_OR_RETURN(map.enabled, args.GetOnOff("map-layers", map.enabled));
  SEMMAP_ASSIGN_OR_RETURN(map.occupancy.resolution_m,
                          args.GetDouble("map-resolution", map.occupancy.resolution_m));
  SEMMAP_ASSIGN_OR_RETURN(map.occupancy.max_range_m,
                          args.GetDouble("map-max-range", map.occupancy.max_range_m));
  SEMMAP_ASSIGN_OR_RETURN(map.cloud.leaf_size_m,
                          args.GetDouble("cloud-voxel", map.cloud.leaf_size_m));
  SEMMAP_ASSIGN_OR_RETURN(map.occupancy.keyframe_voxel_m,
                          args.GetDouble("map-keyframe-voxel", map.occupancy.keyframe_voxel_m));
  SEMMAP_ASSIGN_OR_RETURN(
      long long cloud_budget_mb,
      args.GetInt("map-cloud-budget-mb",
                  static_cast<long long>(map.keyframe_cloud_budget_bytes >> 20)));
  if (cloud_budget_mb < 0 || cloud_budget_mb > (1LL << 20)) {
    return semmap::InvalidArgumentError("--map-cloud-budget-mb must be in [0, 1048576]");
  }
  map.keyframe_cloud_budget_bytes = static_cast<size_t>(cloud_budget_mb) << 20;
  SEMMAP_ASSIGN_OR_RETURN(options->ingest.objects.enabled,
                          args.GetOnOff("objects", options->ingest.objects.enabled));
  SEMMAP_ASSIGN_OR_RETURN(double object_xi,
                          args.GetDouble("object-max-xi", options->recognition.max_xi));
  if (object_xi == 0) {
    options->ingest.objects.apply_xi = false;  // the recogniser's own threshold stays valid
  } else {
    options->recognition.max_xi = object_xi;
  }
  SEMMAP_ASSIGN_OR_RETURN(long long min_inliers,
                          args.GetInt("object-min-inliers", options->recognition.min_inliers));
  options->recognition.min_inliers = static_cast<int>(min_inliers);
  SEMMAP_ASSIGN_OR_RETURN(long long grace, args.GetInt("shutdown-grace-s", 5));
  options->shutdown_grace_s = static_cast<int>(grace);
  return options->Validate();
}

// --check-vo-model: what an operator (or CI, after training) runs before deploying a model.
int CheckVoModel(const std::string& path) {
  const auto model = semmap::MonoVoModel::Load(path);
  if (!model.ok()) {
    std::cerr << "semmapd: VO model not usable: " << model.status().ToString() << "\n";
    return 1;
  }
  const semmap::MonoVoModelInfo& info = (*model)->info();
  std::cout << "semmapd: VO model " << path << " OK: input " << info.camera.width << "x"
            << info.camera.height << " f=" << info.camera.f << ", " << info.state.size()
            << " recurrent inputs, sha256 " << info.sha256 << std::endl;
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  // Before any thread starts: on glibc malloc, sessions and map stages run many threads whose
  // freed memory would otherwise scatter over up to 8 malloc arenas per core.
  semmap::LimitAllocatorArenas(4);
  semmap::ArgParser args;
  args.AddFlag("listen", "HOST:PORT",
               "address to serve on (default 127.0.0.1:50051; port 0 picks one), or unix:/PATH "
               "(a Unix domain socket: for clients on this machine, cheaper than TCP; who may "
               "connect is the path's file permissions)");
  args.AddFlag("data-dir", "DIR", "where the SQLite database lives (default ./semmap-data)");
  args.AddFlag("tls-cert", "FILE",
               "serve TLS with this PEM certificate chain (with --tls-key; default plaintext)");
  args.AddFlag("tls-key", "FILE", "the PEM private key of --tls-cert");
  args.AddFlag("tls-client-ca", "FILE",
               "mutual TLS: serve only clients whose certificate this PEM CA signed");
  args.AddFlag("auth-tokens", "FILE",
               "serve only callers with a bearer token from FILE, one 'token role [maps...]' "
               "a line (roles read, write, admin); re-read on SIGHUP");
  args.AddSwitch("allow-insecure",
                 "serve plaintext on an address other than loopback (refused without it)");
  args.AddFlag("max-open-maps", "N",
               "maps with a live pipeline at once (default 16); a session on one more map is "
               "refused with RESOURCE_EXHAUSTED while all of them are streaming");
  args.AddFlag("max-idle-maps", "N",
               "maps kept warm after their last session ended (default 1); others are released "
               "and restored from the store by their next session");
  args.AddFlag("log-level", "LEVEL", "debug, info, warning, error or off (default info; stderr)");
  args.AddFlag("sqlite-sync", "full|normal", "SQLite synchronous mode (default full)");
  args.AddFlag("queue-capacity", "N", "frames buffered per ingest stream (default 8)");
  args.AddFlag("max-message-mb", "MB", "largest accepted message / frame payload (default 64)");
  args.AddFlag("query-workers", "N",
               "threads answering queries, exports and object registrations, each with its own "
               "database read connection (default 4)");
  args.AddFlag("query-queue", "N",
               "calls waiting for a query worker; one more is refused with RESOURCE_EXHAUSTED "
               "(default 64)");
  args.AddFlag("max-pending-exports", "N",
               "exports running or waiting at once (default 2, at most --query-workers); one "
               "more is refused with RESOURCE_EXHAUSTED");
  args.AddFlag("max-registrations-per-minute", "N",
               "object registrations admitted per minute (default 30, 0: no limit)");
  args.AddFlag(
      "max-streams", "N",
      "concurrent ingest streams; one more is refused with RESOURCE_EXHAUSTED (default 64)");
  args.AddFlag("max-session-fps", "FPS",
               "frames per second one ingest stream may send on average (bursts of two "
               "seconds' worth pass); a faster one ends with RESOURCE_EXHAUSTED, keeping what "
               "came before (default 0: no limit)");
  args.AddFlag("stream-idle-timeout-s", "S",
               "end a stream that sends nothing for S seconds with DEADLINE_EXCEEDED, keeping "
               "what it sent (default 60; 0: never)");
  args.AddFlag("keyframe-min-motion", "M", "keyframe motion threshold (default 0.10)");
  args.AddFlag("keyframe-rotation-weight", "M_PER_RAD",
               "rotation weight in the motion norm (default 0.5)");
  args.AddFlag("keyframe-skip-mapped", "on|off",
               "RGBD: a frame within the keyframe motion threshold of a keyframe the map already "
               "holds (loop-verified, any session's) makes no keyframe, so a map revisited every "
               "day grows less; the back end keeps the tracker's map and the frames' anchors on "
               "the mapped keyframes it passes (default on; off: a keyframe every motion "
               "threshold, as on a first visit)");
  args.AddFlag("vocabulary", "FILE|none",
               "place-recognition vocabulary for loop closure (default: the bundled "
               "models/orb_vocab.bin; none: loops by pose proximity only)");
  args.AddFlag("vo-model", "FILE|none",
               "learned VO network for MONO sessions, with its .json sidecar next to it "
               "(default: the bundled models/vo/semmap_vo.onnx; none: MONO sessions are refused)");
  args.AddFlag("mono-vo", "net|hybrid",
               "how MONO sessions are tracked: the network's motion alone, or feature tracking "
               "on the network's depth (default hybrid)");
  args.AddFlag("loop-max-xi", "X",
               "reject a loop whose candidate matches more than X times better than its "
               "neighbouring keyframes (default 1.25)");
  args.AddFlag("local-ba", "on|off",
               "bundle-adjust each RGBD keyframe with its covisible keyframes and their map "
               "points, and track against the refined points (default on)");
  args.AddFlag("final-ba", "on|off",
               "when an RGBD session ends, bundle-adjust its keyframes and the map points they "
               "see, other sessions' keyframes held fixed (needs --local-ba on; default on)");
  args.AddFlag("point-fusion", "off|on|all",
               "search the map points of the keyframes around each new RGBD keyframe in it: "
               "keypoints join a neighbour's point, a fresh duplicate (seen by one keyframe) "
               "is merged; all: also merge two established points (measured, that costs "
               "ATE); needs --local-ba on; default off)");
  args.AddFlag("slam-features-mb", "MB",
               "keyframe features each open map's SLAM back end keeps in memory; beyond it the "
               "least recently used are read back from the store when loop closure or a "
               "tracker's local map needs them (default 32, ~400 keyframes; 0: all kept)");
  args.AddFlag("map-layers", "on|off",
               "build the 3D layers (OctoMap occupancy, coloured cloud) from keyframes with depth "
               "(default on)");
  args.AddFlag("map-resolution", "M", "occupancy voxel size in metres (default 0.05)");
  args.AddFlag("map-max-range", "M", "depth beyond this is not mapped (default 4.0)");
  args.AddFlag("cloud-voxel", "M", "point-cloud voxel-grid leaf in metres (default 0.02)");
  args.AddFlag("map-keyframe-voxel", "M",
               "each keyframe's cloud is kept as one mean point per cube of this edge, what the "
               "map holds per keyframe for rebuilds (default 0.02; 0: every sampled pixel)");
  args.AddFlag("map-cloud-budget-mb", "MB",
               "keyframe clouds each open map keeps in memory for rebuilds; beyond it the oldest "
               "are read back from the stored keyframes when a rebuild needs them (default 64; "
               "0: none kept once stored)");
  args.AddFlag("objects", "on|off", "recognise registered objects in RGBD keyframes (default on)");
  args.AddFlag("object-max-xi", "X",
               "object neighbour check: reject a detection whose matches exceed its best "
               "neighbour keyframe's by more than this ratio (default 1.25; 0 disables the check)");
  args.AddFlag("object-min-inliers", "N",
               "geometric-verification inliers an object detection needs (default 12)");
  args.AddFlag("shutdown-grace-s", "S", "seconds streams get to finish at shutdown (default 5)");
  args.AddFlag("check-vo-model", "FILE",
               "load a VO model as MONO sessions would (sidecar, sha256, OpenCV import, two "
               "steps), print what it is and exit: 0 usable, 1 not");
  args.AddSwitch("help", "print this help");

  semmap::ServerOptions options;
  // The vocabulary that comes with the source tree; a missing file is a warning, not an error.
  options.vocabulary_path = SEMMAP_DEFAULT_VOCABULARY;
  options.vocabulary_optional = true;
  // Likewise the VO model: without it (or with a damaged one) only MONO sessions are refused.
  options.vo_model_path = SEMMAP_DEFAULT_VO_MODEL;
  options.vo_model_optional = true;
  semmap::Status parsed = args.Parse(argc, argv);
  if (parsed.ok() && args.Has("help")) {
    std::cout << kUsage << args.Usage();
    return 0;
  }
  if (parsed.ok() && args.Has("check-vo-model"))
    return CheckVoModel(args.Get("check-vo-model", ""));
  if (parsed.ok() && !args.positional().empty()) {
    parsed = semmap::InvalidArgumentError("unexpected argument '" + args.positional()[0] + "'");
  }
  if (parsed.ok()) parsed = ParseOptions(args, &options);
  if (!parsed.ok()) {
    std::cerr << "semmapd: " << parsed.message() << "\n(see semmapd --help)\n";
    return 2;
  }

  // Block the stop signals in every thread (gRPC's included), then wait for them here.
  sigset_t stop_signals;
  sigemptyset(&stop_signals);
  sigaddset(&stop_signals, SIGINT);
  sigaddset(&stop_signals, SIGTERM);
  sigaddset(&stop_signals, SIGHUP);  // not a stop: re-reads --auth-tokens
  pthread_sigmask(SIG_BLOCK, &stop_signals, nullptr);

  semmap::SetLogLevel(options.log_level);
  semmap::LogInfo("starting with {} (allocator: {})", options.ToString(), semmap::AllocatorName());
  auto server = semmap::SemmapServer::Start(options);
  if (!server.ok()) {
    semmap::LogError("{}", server.status().ToString());
    return 1;
  }
  // Machine-readable line: scripts and tests wait for it to learn the port.
  std::cout << "semmapd: listening on " << (*server)->address() << std::endl;

  int signal_number = 0;
  while (sigwait(&stop_signals, &signal_number) == 0 && signal_number == SIGHUP) {
    const semmap::Status reloaded = (*server)->ReloadAuthTokens();
    if (!reloaded.ok()) semmap::LogWarning("SIGHUP: {}", reloaded.ToString());
  }
  semmap::LogInfo("received {}, shutting down", signal_number == SIGINT ? "SIGINT" : "SIGTERM");
  semmap::Status stopped = (*server)->Shutdown();
  if (!stopped.ok()) {
    semmap::LogError("shutdown: {}", stopped.ToString());
    return 1;
  }
  semmap::LogInfo("stopped cleanly");
  return 0;
}
