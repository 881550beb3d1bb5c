// crash_bench: semmapd killed with SIGKILL at random moments, again and again, and restarted.
// Each round starts semmapd on one data directory and, before anything else, checks what the
// previous kill left: the database passes integrity_check, every frame the client saw
// acknowledged as durable is stored, and the map reloads (sessions, objects, the stored 3D
// layer). Then it kills the server during one of:
//   ingest  an RGBD stream of a real sequence (default TUM fr3/teddy), SLAM, layers, objects;
//   export  a layer export rebuilt from every stored keyframe of a session;
//   remove  a session removal (the map's layers and objects rebuilt from the rest).
// Prints the rounds, frames acknowledged, frames lost (the goal is 0) and any failure; exits 1
// on a loss or failure.
//
//   crash_bench [--rounds 100] [--dataset DIR] [--seed 1] [--keep DIR]
#include <csignal>
#include <filesystem>
#include <future>
#include <iostream>
#include <map>
#include <optional>
#include <random>
#include <string>
#include <thread>
#include <vector>

#include "client/datasets/dataset.h"
#include "client/lib/map_client.h"
#include "client/lib/wire_frame.h"
#include "common/arg_parser.h"
#include "server/serialization/conversions.h"
#include "storage/sqlite/sqlite_map_store.h"
#include "tests/testing/server_process.h"
#include "tests/testing/temp_dir.h"

namespace semmap {
namespace {

constexpr char kMap[] = "crash";
constexpr char kStoredLayerFormat[] = "ot";  // exported from the stored blob, no rebuild

struct Tally {
  int rounds = 0;
  std::map<std::string, int> kills;  // by action
  uint64_t acknowledged = 0;         // frames the client saw acknowledged durable
  uint64_t lost = 0;                 // of those, frames missing after the restart
  int integrity_failures = 0;
  int reload_failures = 0;
  int removed_before_kill = 0;  // removals that committed before the kill
};

// What the client was told was durable, per session.
struct Acknowledged {
  std::optional<uint64_t> durable_seq;
  bool removal_asked = false;  // a removal was under way when the server died
};

StatusOr<std::vector<v1::Frame>> LoadFrames(const Dataset& dataset) {
  std::vector<v1::Frame> frames;
  for (const DatasetFrame& f : dataset.frames) {
    SEMMAP_ASSIGN_OR_RETURN(frames.emplace_back(),
                            MakeWireFrame(f, true, dataset.depth_scale, std::nullopt));
  }
  return frames;
}

// The checks after a restart. Returns false (and says why) on a failure other than lost frames,
// which it counts.
bool CheckReload(MapClient& client, std::map<std::string, Acknowledged>& sessions, Tally& tally) {
  auto listed = client.ListSessions(kMap);
  if (!listed.ok()) {
    if (sessions.empty() && listed.status().code() == StatusCode::kNotFound) return true;
    std::cerr << "  reload: ListSessions: " << listed.status().ToString() << "\n";
    return false;
  }
  std::map<std::string, SessionInfo> present;
  for (const SessionInfo& s : *listed) present[s.name] = s;
  for (auto it = sessions.begin(); it != sessions.end();) {
    const auto& [name, acked] = *it;
    if (present.count(name) == 0) {
      if (acked.removal_asked) {
        ++tally.removed_before_kill;  // the removal committed whole
      } else if (acked.durable_seq) {
        std::cerr << "  session " << name << " is gone with " << *acked.durable_seq + 1
                  << " durable frames\n";
        tally.lost += *acked.durable_seq + 1;
      }
      it = sessions.erase(it);
      continue;
    }
    it->second.removal_asked = false;  // the removal did not commit: it is whole again
    if (acked.durable_seq) {
      auto trajectory = client.GetTrajectory(kMap, name, false);
      if (!trajectory.ok()) {
        std::cerr << "  reload: trajectory of " << name << ": " << trajectory.status().ToString()
                  << "\n";
        return false;
      }
      std::vector<bool> seen(*acked.durable_seq + 1, false);
      for (const TrajectoryPose& p : *trajectory) {
        if (p.seq >= 0 && static_cast<uint64_t>(p.seq) <= *acked.durable_seq) seen[p.seq] = true;
      }
      for (bool s : seen) tally.lost += s ? 0 : 1;
    }
    ++it;
  }
  if (auto objects = client.FindObjects("", kMap); !objects.ok()) {
    std::cerr << "  reload: objects: " << objects.status().ToString() << "\n";
    return false;
  }
  ExportRequest layer;
  layer.map = kMap;
  layer.format = std::string(kStoredLayerFormat);
  auto exported = client.ExportMap(layer);
  if (!exported.ok() && exported.status().code() != StatusCode::kNotFound) {
    std::cerr << "  reload: stored occupancy layer: " << exported.status().ToString() << "\n";
    return false;
  }
  return true;
}

int Run(int argc, const char* const* argv) {
  ArgParser args;
  args.AddFlag("rounds", "N", "kills (default 100)");
  args.AddFlag("dataset", "DIR", "TUM-layout RGB-D sequence (default: the shared teddy)");
  args.AddFlag("seed", "N", "random seed of the kill moments (default 1)");
  args.AddFlag("keep", "DIR", "data directory to use and keep (default: a temporary one)");
  if (Status parsed = args.Parse(argc, argv); !parsed.ok()) {
    std::cerr << "crash_bench: " << parsed.message() << "\n" << args.Usage();
    return 2;
  }
  const auto rounds = args.GetInt("rounds", 100);
  const auto seed = args.GetInt("seed", 1);
  if (!rounds.ok() || !seed.ok() || *rounds < 1) {
    std::cerr << "crash_bench: --rounds and --seed must be numbers, rounds >= 1\n";
    return 2;
  }
  const std::string dataset_dir =
      args.Get("dataset", testing::SharedDataDir() + "/tum_fr3_teddy_200");
  StatusOr<Dataset> dataset = OpenDataset(dataset_dir);
  if (!dataset.ok()) {
    std::cerr << "crash_bench: " << dataset.status().ToString() << "\n";
    return 2;
  }
  StatusOr<std::vector<v1::Frame>> frames = LoadFrames(*dataset);
  if (!frames.ok() || frames->empty() || dataset->depth_scale <= 0) {
    std::cerr << "crash_bench: " << dataset_dir << " needs colour and depth frames\n";
    return 2;
  }
  testing::TempDir temp;
  const std::string data_dir = args.Get("keep", temp.File("data"));
  std::filesystem::create_directories(data_dir);

  std::mt19937 rng(static_cast<uint32_t>(*seed));
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  std::map<std::string, Acknowledged> sessions;
  Tally tally;
  const auto t0 = std::chrono::steady_clock::now();
  std::cout << "crash_bench: " << *rounds << " SIGKILL rounds on " << dataset_dir << " ("
            << frames->size() << " frames), data " << data_dir << std::endl;

  for (int64_t round = 0; round <= *rounds; ++round) {
    testing::ServerProcess server;
    if (Status started = server.Start(data_dir, {"--log-level", "error"}); !started.ok()) {
      std::cerr << "round " << round << ": semmapd does not start: " << started.ToString() << "\n";
      ++tally.reload_failures;
      break;
    }
    ClientOptions options;
    options.server = server.address();
    options.query_timeout = std::chrono::seconds(120);
    MapClient client(options);
    if (!CheckReload(client, sessions, tally)) ++tally.reload_failures;
    if (round == *rounds) {
      server.Stop(SIGTERM);
      break;
    }

    // The action: mostly ingest; an export or a removal once there is something to act on.
    const double pick = unit(rng);
    std::string action = "ingest";
    if (sessions.size() >= 2 && pick > 0.9) {
      action = "remove";
    } else if (!sessions.empty() && pick > 0.7) {
      action = "export";
    }
    ++tally.kills[action];
    if (action == "ingest") {
      const std::string name = "round" + std::to_string(round);
      v1::IngestStart start;
      start.set_map(kMap);
      start.set_session(name);
      start.set_mode(v1::SESSION_MODE_RGBD);
      ToProto(dataset->camera, start.mutable_camera());
      auto stream = client.Ingest(start);
      if (!stream.ok()) {
        std::cerr << "round " << round << ": " << stream.status().ToString() << "\n";
        ++tally.reload_failures;
        continue;
      }
      std::thread writer([&] {
        for (const v1::Frame& frame : *frames) {
          if (!(*stream)->Write(v1::Frame(frame)).ok()) return;
        }
        (void)(*stream)->Finish();
      });
      // Somewhere in a stream's life (teddy takes ~5-10 s here), now and then after its end.
      std::this_thread::sleep_for(std::chrono::duration<double>(0.2 + 9.0 * unit(rng)));
      server.Stop(SIGKILL);
      writer.join();
      const std::optional<uint64_t> durable = (*stream)->durable_seq();
      sessions[name].durable_seq = durable;
      tally.acknowledged += durable ? *durable + 1 : 0;
    } else if (action == "export") {
      ExportRequest request;
      request.map = kMap;
      request.format = "ply";
      request.session = sessions.begin()->first;  // rebuilt from its stored keyframes
      request.voxel_m = 0.01;
      auto exported = std::async(std::launch::async, [&] { return client.ExportMap(request); });
      std::this_thread::sleep_for(std::chrono::duration<double>(1.5 * unit(rng)));
      server.Stop(SIGKILL);
      exported.wait();
    } else {
      auto victim = sessions.begin();
      victim->second.removal_asked = true;
      auto removed =
          std::async(std::launch::async, [&] { return client.RemoveSession(kMap, victim->first); });
      std::this_thread::sleep_for(std::chrono::duration<double>(2.0 * unit(rng)));
      server.Stop(SIGKILL);
      removed.wait();
    }
    auto store = SqliteMapStore::Open(data_dir + "/semmap.db", SqliteOptions{});
    if (!store.ok() || !(*store)->IntegrityCheck().ok()) {
      std::cerr << "round " << round << ": integrity check failed\n";
      ++tally.integrity_failures;
    }
    ++tally.rounds;
    if (tally.rounds % 10 == 0) {
      std::cout << "  " << tally.rounds << " rounds, " << tally.lost << " frames lost, "
                << tally.integrity_failures + tally.reload_failures << " failures" << std::endl;
    }
  }
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  std::cout << "crash_bench: " << tally.rounds << " rounds in " << static_cast<int>(seconds)
            << " s (kills during";
  for (const auto& [action, count] : tally.kills) std::cout << " " << action << " " << count;
  std::cout << ")\n  frames acknowledged durable: " << tally.acknowledged
            << "\n  frames lost: " << tally.lost
            << "\n  integrity_check failures: " << tally.integrity_failures
            << "\n  reload failures: " << tally.reload_failures
            << "\n  removals that committed before the kill: " << tally.removed_before_kill
            << std::endl;
  return tally.lost == 0 && tally.integrity_failures == 0 && tally.reload_failures == 0 ? 0 : 1;
}

}  // namespace
}  // namespace semmap

int main(int argc, char** argv) { return semmap::Run(argc, argv); }
