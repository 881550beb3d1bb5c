// Object-location queries over a store holding 10,000 object instances of 50 types in one map
// (random positions in a 60 x 60 x 3 m building), through StoreMapQuery (the server's query
// path without gRPC):
//   BM_FindObjects         `where LABEL`: the ~200 instances of one label
//   BM_ObjectsNear/R       `near X Y Z R`: R = 2 m and 10 m around random points (R*Tree)
// Each reports p50 / p99 per query as counters (the goal is the p99).
#include <benchmark/benchmark.h>

#include <algorithm>
#include <chrono>
#include <cstdlib>
#include <memory>
#include <random>
#include <string>
#include <vector>

#include "core/query/store_map_query.h"
#include "storage/sqlite/sqlite_map_store.h"
#include "tests/testing/temp_dir.h"

namespace semmap {
namespace {

constexpr int kTypes = 50;
constexpr int kInstances = 10000;

struct Fixture {
  testing::TempDir dir;
  std::unique_ptr<StoreMapQuery> query;
};

Fixture& Shared() {
  static Fixture* const fixture = [] {
    auto* f = new Fixture;
    const std::string db = f->dir.File("semmap.db");
    StatusOr<std::unique_ptr<SqliteMapStore>> store = SqliteMapStore::Open(db, {});
    if (!store.ok()) std::abort();
    StatusOr<MapInfo> map = (*store)->GetOrCreateMap("building");
    SessionInfo session;
    session.map_id = map->id;
    session.name = "walk";
    session.camera = {640, 480, 525, 525, 319.5, 239.5};
    StatusOr<SessionInfo> created = (*store)->CreateSession(session);
    if (!map.ok() || !created.ok()) std::abort();
    std::vector<int64_t> type_ids;
    for (int t = 0; t < kTypes; ++t) {
      ObjectType type;
      type.label = "object_" + std::to_string(t);
      ObjectView view;
      view.image = {"png", "x"};
      view.features_format = "semmap-features-v1";
      view.features = "f";
      type.views.push_back(view);
      StatusOr<ObjectType> stored = (*store)->CreateObjectType(type);
      if (!stored.ok()) std::abort();
      type_ids.push_back(stored->id);
    }
    std::mt19937 rng(7);
    std::uniform_real_distribution<double> xy(0, 60), z(0, 3);
    std::vector<ObjectInstance> instances;
    for (int i = 0; i < kInstances; ++i) {
      ObjectInstance o;
      o.map_id = map->id;
      o.type_id = type_ids[static_cast<size_t>(i % kTypes)];
      o.label = "object_" + std::to_string(i % kTypes);
      o.position = {xy(rng), xy(rng), z(rng)};
      o.extent = {0.3, 0.3, 0.3};
      o.confidence = 0.8;
      o.observations = 3;
      o.session_ids = {created->id};
      instances.push_back(o);
    }
    WriteBatch batch;
    batch.instances.emplace_back(map->id, std::move(instances));
    if (!(*store)->Write(batch).ok()) std::abort();
    StatusOr<std::unique_ptr<SqliteMapStore>> read = SqliteMapStore::Open(db, {});
    if (!read.ok()) std::abort();
    f->query = std::make_unique<StoreMapQuery>(std::move(read).value());
    return f;
  }();
  return *fixture;
}

void Percentiles(benchmark::State& state, std::vector<double>& ms, double results) {
  std::sort(ms.begin(), ms.end());
  if (ms.empty()) return;
  state.counters["p50_ms"] = ms[ms.size() / 2];
  state.counters["p99_ms"] = ms[std::min(ms.size() - 1, ms.size() * 99 / 100)];
  state.counters["results"] = results / static_cast<double>(ms.size());
}

void BM_FindObjects(benchmark::State& state) {
  Fixture& f = Shared();
  std::vector<double> ms;
  double results = 0;
  int i = 0;
  for (auto _ : state) {
    const auto t0 = std::chrono::steady_clock::now();
    StatusOr<std::vector<ObjectInstance>> found =
        f.query->FindObjects("object_" + std::to_string(i++ % kTypes), "building");
    ms.push_back(
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count());
    if (!found.ok()) state.SkipWithError(found.status().ToString().c_str());
    results += static_cast<double>(found->size());
  }
  Percentiles(state, ms, results);
}
BENCHMARK(BM_FindObjects);

void BM_ObjectsNear(benchmark::State& state) {
  Fixture& f = Shared();
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> xy(0, 60), z(0, 3);
  const double radius = static_cast<double>(state.range(0));
  std::vector<double> ms;
  double results = 0;
  for (auto _ : state) {
    const Eigen::Vector3d p(xy(rng), xy(rng), z(rng));
    const auto t0 = std::chrono::steady_clock::now();
    StatusOr<std::vector<ObjectInstance>> found = f.query->ObjectsNear("building", p, radius, "");
    ms.push_back(
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count());
    if (!found.ok()) state.SkipWithError(found.status().ToString().c_str());
    results += static_cast<double>(found->size());
  }
  Percentiles(state, ms, results);
}
BENCHMARK(BM_ObjectsNear)->Arg(2)->Arg(10);

}  // namespace
}  // namespace semmap

BENCHMARK_MAIN();
