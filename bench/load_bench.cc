// load_bench: semmapd under mixed load, as a service shared by a household of devices would be.
// It starts semmapd (a child process, so its memory and descriptors are its own) and runs at
// once: N KNOWN_POSES sessions and M RGBD sessions of a real sequence (default TUM fr3/teddy,
// ground truth as the known poses), each into its own map, as fast as the server takes them;
// and a query client asking `where` (FindObjects) and `near` (ObjectsNear, 2 m) alternately at
// a fixed rate over those maps. It samples the server's RSS and open file descriptors every
// second. Prints per-session frames/s, query p50/p99/max during ingest (from each query's slot
// in the fixed-rate schedule, so a stall counts for every query it held up), RSS and
// descriptors over time, and every error; exits 1 on an error.
//
// --duration-s S makes it a soak: sessions start again (a new session each time) until S
// seconds have passed; RSS and descriptors are then reported per minute, first vs last.
//
// Then, on the stored data with the server stopped: cancel-to-stop of an export that rebuilds
// an RGBD map's occupancy layer (the longest work a query worker does). The export runs once
// whole, then --cancel-rounds times cancelled at spread fractions of that time; each prints
// how long after its cancellation the export returned (the goal is under 100 ms).
//
//   load_bench [--known-poses 8] [--rgbd 4] [--query-hz 100] [--duration-s 0] [--dataset DIR]
//              [--cancel-rounds 8]
#include <dirent.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <csignal>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <map>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "client/datasets/dataset.h"
#include "client/datasets/pose_lookup.h"
#include "client/lib/map_client.h"
#include "client/lib/wire_frame.h"
#include "common/arg_parser.h"
#include "core/query/store_map_query.h"
#include "server/serialization/conversions.h"
#include "storage/sqlite/sqlite_map_store.h"
#include "tests/testing/server_process.h"
#include "tests/testing/temp_dir.h"

namespace semmap {
namespace {

using Clock = std::chrono::steady_clock;

double SecondsSince(Clock::time_point t0) {
  return std::chrono::duration<double>(Clock::now() - t0).count();
}

// VmRSS of a process in MiB (0 when it cannot be read).
double RssMiB(pid_t pid) {
  std::ifstream status("/proc/" + std::to_string(pid) + "/status");
  std::string key;
  while (status >> key) {
    if (key == "VmRSS:") {
      double kib = 0;
      status >> kib;
      return kib / 1024.0;
    }
    status.ignore(1 << 12, '\n');
  }
  return 0;
}

int OpenFds(pid_t pid) {
  DIR* dir = ::opendir(("/proc/" + std::to_string(pid) + "/fd").c_str());
  if (dir == nullptr) return -1;
  int count = 0;
  while (const dirent* entry = ::readdir(dir)) count += entry->d_name[0] == '.' ? 0 : 1;
  ::closedir(dir);
  return count;
}

struct SessionResult {
  std::string map;
  std::string mode;
  uint64_t frames = 0;
  double seconds = 0;
  int runs = 0;
  std::vector<std::string> errors;
};

struct Sample {
  double t = 0;
  double rss_mib = 0;
  int fds = 0;
  double db_mib = 0;  // database + WAL: what the maps hold, to set RSS growth against
};

// Size of the files at `paths` in MiB (missing ones count 0).
double FilesMiB(const std::vector<std::string>& paths) {
  uintmax_t bytes = 0;
  for (const std::string& path : paths) {
    std::error_code ec;
    const uintmax_t size = std::filesystem::file_size(path, ec);
    if (!ec) bytes += size;
  }
  return static_cast<double>(bytes) / (1 << 20);
}

double Percentile(std::vector<double> values, double q) {
  if (values.empty()) return 0;
  std::sort(values.begin(), values.end());
  const auto rank = static_cast<size_t>(std::lround(q * static_cast<double>(values.size() - 1)));
  return values[std::min(rank, values.size() - 1)];
}

StatusOr<std::vector<v1::Frame>> LoadFrames(const Dataset& dataset, const PoseLookup* poses) {
  std::vector<v1::Frame> frames;
  for (const DatasetFrame& f : dataset.frames) {
    std::optional<Eigen::Isometry3d> T;
    if (poses != nullptr && !(T = poses->At(f.stamp_ns))) continue;  // no pose: not sent
    SEMMAP_ASSIGN_OR_RETURN(frames.emplace_back(), MakeWireFrame(f, true, dataset.depth_scale, T));
  }
  return frames;
}

// One device: streams the frames into `map`, again as a new session while `more()` says so.
void RunSession(MapClient& client, const Dataset& dataset, v1::SessionMode mode,
                const std::vector<v1::Frame>& frames, const std::function<bool()>& more,
                SessionResult* result) {
  const Clock::time_point t0 = Clock::now();
  do {
    v1::IngestStart start;
    start.set_map(result->map);
    start.set_session(result->map + "-" + std::to_string(result->runs));
    start.set_mode(mode);
    ToProto(dataset.camera, start.mutable_camera());
    auto stream = client.Ingest(start);
    if (!stream.ok()) {
      result->errors.push_back(stream.status().ToString());
      return;
    }
    Status written = OkStatus();
    for (const v1::Frame& frame : frames) {
      written = (*stream)->Write(v1::Frame(frame));
      if (!written.ok()) break;
    }
    auto summary = (*stream)->Finish();
    if (!summary.ok()) {
      result->errors.push_back(summary.status().ToString());
      return;
    }
    result->frames += summary->frames();
    ++result->runs;
  } while (more());
  result->seconds = SecondsSince(t0);
}

// Cancel-to-stop of a rebuilt occupancy export of `map` (see the top). Returns false on error.
bool MeasureExportCancel(const std::string& db_path, const std::string& map, int rounds) {
  auto store = SqliteMapStore::Open(db_path, SqliteOptions{});
  if (!store.ok()) {
    std::cout << "  export cancel: cannot open " << db_path << ": " << store.status().ToString()
              << "\n";
    return false;
  }
  StoreMapQuery query(std::move(store).value());
  ExportRequest request;
  request.map = map;
  request.format = "ot";
  request.voxel_m = 0.03;  // not the map's own resolution: the layer is rebuilt from keyframes
  const Clock::time_point whole_start = Clock::now();
  auto whole = query.ExportMap(request);
  const double whole_ms = 1000.0 * SecondsSince(whole_start);
  if (!whole.ok()) {
    std::cout << "  export cancel: the whole export failed: " << whole.status().ToString() << "\n";
    return false;
  }
  std::vector<double> stop_ms;
  for (int round = 0; round < rounds; ++round) {
    const double cancel_after_ms = whole_ms * (round + 0.5) / rounds;
    const Clock::time_point start = Clock::now();
    const Clock::time_point cancel_at =
        start + std::chrono::duration_cast<Clock::duration>(
                    std::chrono::duration<double, std::milli>(cancel_after_ms));
    auto cancelled = query.ExportMap(request, [&] {
      return Clock::now() >= cancel_at ? CancelledError("cancelled by the bench") : OkStatus();
    });
    const Clock::time_point returned = Clock::now();
    if (cancelled.ok()) continue;  // finished before the cancel took effect
    if (cancelled.status().code() != StatusCode::kCancelled) {
      std::cout << "  export cancel: " << cancelled.status().ToString() << "\n";
      return false;
    }
    stop_ms.push_back(std::chrono::duration<double, std::milli>(returned - cancel_at).count());
  }
  std::cout << std::setprecision(1) << "  export cancel (" << map << ", occupancy rebuilt at "
            << std::setprecision(2) << request.voxel_m << std::setprecision(1) << " m: " << whole_ms
            << " ms whole, " << whole->bytes.size() << " bytes): " << stop_ms.size() << " of "
            << rounds << " cancelled in flight, stopped after p50 " << Percentile(stop_ms, 0.5)
            << " ms, max " << Percentile(stop_ms, 1.0) << " ms\n";
  return true;
}

int Run(int argc, const char* const* argv) {
  ArgParser args;
  args.AddFlag("known-poses", "N", "KNOWN_POSES sessions at once (default 8)");
  args.AddFlag("rgbd", "N", "RGBD sessions at once (default 4)");
  args.AddFlag("query-hz", "HZ", "where / near queries per second (default 100)");
  args.AddFlag("duration-s", "S", "soak: keep streaming new sessions for S seconds (default 0)");
  args.AddFlag("dataset", "DIR", "TUM-layout RGB-D sequence with ground truth (default teddy)");
  args.AddFlag("cancel-rounds", "N", "cancelled exports measured after the load (default 8)");
  args.AddFlag("map-cloud-budget-mb", "MB",
               "semmapd's keyframe cloud budget per map (default: semmapd's); a small one "
               "shows the plateau within a short soak");
  if (Status parsed = args.Parse(argc, argv); !parsed.ok()) {
    std::cerr << "load_bench: " << parsed.message() << "\n" << args.Usage();
    return 2;
  }
  const auto known = args.GetInt("known-poses", 8);
  const auto rgbd = args.GetInt("rgbd", 4);
  const auto query_hz = args.GetDouble("query-hz", 100);
  const auto duration_s = args.GetDouble("duration-s", 0);
  const auto cancel_rounds = args.GetInt("cancel-rounds", 8);
  if (!known.ok() || !rgbd.ok() || !query_hz.ok() || !duration_s.ok() || !cancel_rounds.ok() ||
      *known < 0 || *rgbd < 0 || *known + *rgbd < 1 || *query_hz <= 0 || *duration_s < 0 ||
      *cancel_rounds < 0) {
    std::cerr << "load_bench: bad numbers\n" << args.Usage();
    return 2;
  }
  const std::string dataset_dir =
      args.Get("dataset", testing::SharedDataDir() + "/tum_fr3_teddy_200");
  StatusOr<Dataset> dataset = OpenDataset(dataset_dir);
  if (!dataset.ok() || dataset->ground_truth.empty() || dataset->depth_scale <= 0) {
    std::cerr << "load_bench: " << dataset_dir << " needs depth and ground truth"
              << (dataset.ok() ? "" : ": " + dataset.status().ToString()) << "\n";
    return 2;
  }
  const PoseLookup poses(dataset->ground_truth);
  auto rgbd_frames = LoadFrames(*dataset, nullptr);
  auto known_frames = LoadFrames(*dataset, &poses);
  if (!rgbd_frames.ok() || !known_frames.ok()) {
    std::cerr << "load_bench: cannot read the frames\n";
    return 2;
  }

  testing::TempDir temp;
  testing::ServerProcess server;
  // Room for every map to stay open: the bench measures load, not map eviction.
  const std::string max_maps = std::to_string(*known + *rgbd + 1);
  std::vector<std::string> server_args = {"--log-level", "warning",         "--max-open-maps",
                                          max_maps,      "--max-idle-maps", max_maps};
  if (args.Has("map-cloud-budget-mb")) {
    server_args.emplace_back("--map-cloud-budget-mb");
    server_args.push_back(args.Get("map-cloud-budget-mb", ""));
  }
  if (Status started = server.Start(temp.File("data"), server_args); !started.ok()) {
    std::cerr << "load_bench: semmapd does not start: " << started.ToString() << "\n";
    return 1;
  }
  ClientOptions options;
  options.server = server.address();
  // Each device and the app have their own connection, as separate machines would.
  MapClient app_client(options);

  std::atomic<bool> ingesting{true};
  std::mutex samples_mutex;
  std::vector<Sample> samples;
  const Clock::time_point t0 = Clock::now();
  const std::string db_path = temp.File("data") + "/semmap.db";
  std::thread sampler([&] {
    while (ingesting.load()) {
      {
        std::lock_guard lock(samples_mutex);
        samples.push_back({SecondsSince(t0), RssMiB(server.pid()), OpenFds(server.pid()),
                           FilesMiB({db_path, db_path + "-wal"})});
      }
      std::this_thread::sleep_for(std::chrono::seconds(1));
    }
  });

  std::vector<SessionResult> results(static_cast<size_t>(*known + *rgbd));
  auto more = [&] { return *duration_s > 0 && SecondsSince(t0) < *duration_s; };
  std::vector<std::thread> devices;
  for (size_t i = 0; i < results.size(); ++i) {
    const bool is_known = static_cast<int64_t>(i) < *known;
    results[i].mode = is_known ? "KNOWN_POSES" : "RGBD";
    results[i].map = (is_known ? "kp" : "rgbd") + std::to_string(is_known ? i : i - *known);
    devices.emplace_back([&, i, is_known] {
      MapClient client(options);
      RunSession(client, *dataset, is_known ? v1::SESSION_MODE_KNOWN_POSES : v1::SESSION_MODE_RGBD,
                 is_known ? *known_frames : *rgbd_frames, more, &results[i]);
    });
  }

  // The app: where / near over the maps being built, at a fixed rate.
  std::vector<double> where_ms, near_ms;
  std::vector<std::string> query_errors;
  std::thread app([&] {
    const auto period = std::chrono::duration<double>(1.0 / *query_hz);
    Clock::time_point next = Clock::now();
    for (uint64_t n = 0; ingesting.load(); ++n) {
      const std::string& map = results[n % results.size()].map;
      // Latency counts from the query's slot in the schedule, not from when it was sent: a
      // stalled query delays the ones behind it, and they are charged that wait (an app asking
      // at a fixed rate sees it), instead of silently being asked fewer times.
      const Clock::time_point slot = next;
      Status status = OkStatus();
      if (n % 2 == 0) {
        status = app_client.FindObjects("", map).status();
      } else {
        status = app_client.ObjectsNear(map, Eigen::Vector3d(0.5, 0.0, 1.0), 2.0, "").status();
      }
      const double ms = 1000.0 * SecondsSince(slot);
      // A map no session has created yet is not an error of the server's.
      if (status.ok()) {
        (n % 2 == 0 ? where_ms : near_ms).push_back(ms);
      } else if (status.code() != StatusCode::kNotFound) {
        query_errors.push_back(status.ToString());
      }
      next += std::chrono::duration_cast<Clock::duration>(period);
      std::this_thread::sleep_until(next);
    }
  });

  for (std::thread& device : devices) device.join();
  const double ingest_s = SecondsSince(t0);
  ingesting.store(false);
  app.join();
  sampler.join();
  const int exit_code = server.Stop(SIGTERM);

  std::cout << std::fixed << std::setprecision(1);
  std::cout << "load_bench: " << *known << " KNOWN_POSES + " << *rgbd << " RGBD sessions of "
            << dataset_dir << " (" << rgbd_frames->size() << " frames), queries at " << *query_hz
            << " Hz, " << ingest_s << " s on " << std::thread::hardware_concurrency() << " cores\n";
  size_t errors = query_errors.size();
  for (const SessionResult& r : results) {
    std::cout << "  " << std::setw(11) << r.mode << " " << std::setw(6) << r.map << ": " << r.frames
              << " frames in " << r.runs << " session(s), "
              << (r.seconds > 0 ? r.frames / r.seconds : 0) << " frames/s\n";
    for (const std::string& e : r.errors) std::cout << "    error: " << e << "\n";
    errors += r.errors.size();
  }
  std::cout << std::setprecision(2) << "  where: " << where_ms.size() << " queries, p50 "
            << Percentile(where_ms, 0.5) << " ms, p99 " << Percentile(where_ms, 0.99) << " ms, max "
            << Percentile(where_ms, 1.0) << " ms\n"
            << "  near:  " << near_ms.size() << " queries, p50 " << Percentile(near_ms, 0.5)
            << " ms, p99 " << Percentile(near_ms, 0.99) << " ms, max " << Percentile(near_ms, 1.0)
            << " ms\n";
  for (size_t i = 0; i < std::min<size_t>(query_errors.size(), 5); ++i) {
    std::cout << "    query error: " << query_errors[i] << "\n";
  }
  // RSS and descriptors: every 10 s (every minute in a soak), and the peak.
  const double every = *duration_s > 0 ? 60.0 : 10.0;
  double peak = 0, next_print = 0;
  std::cout << std::setprecision(0) << "  server RSS MiB / open fds / database MiB over time:";
  for (const Sample& s : samples) {
    peak = std::max(peak, s.rss_mib);
    if (s.t >= next_print) {
      std::cout << " " << static_cast<int>(s.t) << "s:" << s.rss_mib << "/" << s.fds << "/"
                << s.db_mib;
      next_print += every;
    }
  }
  if (!samples.empty()) {
    std::cout << " end:" << samples.back().rss_mib << "/" << samples.back().fds << "/"
              << samples.back().db_mib;
  }
  std::cout << "\n  peak RSS " << peak << " MiB; errors " << errors << "; semmapd exit "
            << exit_code << "\n";
  bool cancel_ok = true;
  if (*rgbd > 0 && *cancel_rounds > 0) {
    cancel_ok = MeasureExportCancel(temp.File("data") + "/semmap.db", "rgbd0",
                                    static_cast<int>(*cancel_rounds));
  }
  return errors == 0 && exit_code == 0 && cancel_ok ? 0 : 1;
}

}  // namespace
}  // namespace semmap

int main(int argc, char** argv) { return semmap::Run(argc, argv); }
