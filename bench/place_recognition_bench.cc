// Place recognition (core/slam) with the shipped vocabulary (models/orb_vocab.bin, k 10, L 4):
//   BM_Transform      BowVocabulary::Transform of the 1000 ORB descriptors of a synthetic
//                     640x480 frame (with the direct index at level 2: BM_Transform/2)
//   BM_Query/N        PlaceDatabase::Query, top 10, against N entries (100, 1000, 10000)
//   BM_BruteForce/N   BowVocabulary::Score against every entry, for comparison
// Database entries are drawn like real images: 1000 features whose words follow the document
// frequencies of the vocabulary's training images (df = exp(-idf)), weighted by TF-IDF. The
// counters give the work per query: postings read and entries scored (entries sharing a word).
#include <benchmark/benchmark.h>

#include <cmath>
#include <cstdlib>
#include <map>
#include <random>
#include <vector>

#include "core/odometry/feature_extractor.h"
#include "core/slam/bow_vocabulary.h"
#include "core/slam/place_database.h"
#include "tests/testing/synth/default_scene.h"
#include "tests/testing/synth/renderer.h"
#include "tests/testing/synth/sequence_writer.h"
#include "tests/testing/synth/trajectory.h"

namespace semmap {
namespace {

const BowVocabulary& Vocabulary() {
  static const BowVocabulary* const v = [] {
    StatusOr<BowVocabulary> loaded =
        BowVocabulary::Load(std::string(SEMMAP_SOURCE_DIR) + "/models/orb_vocab.bin");
    if (!loaded.ok()) std::abort();
    return new BowVocabulary(std::move(loaded).value());
  }();
  return *v;
}

cv::Mat FrameDescriptors() {
  const CameraCalibration camera = synth::DefaultSyntheticCamera();
  StatusOr<synth::Scene> scene = synth::MakeDefaultRoomScene(1);
  if (!scene.ok()) std::abort();
  StatusOr<synth::Renderer> renderer = synth::Renderer::Create(*scene, camera);
  StatusOr<std::vector<StampedPose>> poses = synth::CircleTrajectory(scene->room, {});
  StatusOr<FeatureExtractor> extractor = FeatureExtractor::Create({}, camera);
  if (!renderer.ok() || !poses.ok() || !extractor.ok()) std::abort();
  const synth::RenderedFrame f = renderer->Render((*poses)[0].T_world_camera);
  StatusOr<FrameFeatures> features = extractor->Extract(f.bgr, f.depth, synth::kDepthScale);
  if (!features.ok()) std::abort();
  return features->descriptors;
}

// A BowVector like a real image's: `features` words drawn by document frequency.
BowVector SampleImage(std::discrete_distribution<WordId>& df, std::mt19937_64& rng, int features) {
  std::map<WordId, double> counts;
  for (int i = 0; i < features; ++i) {
    const WordId w = df(rng);
    counts[w] += Vocabulary().Weight(w);
  }
  BowVector bow;
  double total = 0;
  for (const auto& [w, x] : counts) {
    if (x > 0) bow.push_back({w, x}), total += x;
  }
  for (BowEntry& e : bow) e.weight /= total;
  return bow;
}

struct Fixture {
  PlaceDatabase db;
  std::vector<BowVector> entries;
  std::vector<BowVector> queries;
};

const Fixture& Database(int entries) {
  static std::map<int, Fixture>* const cache = new std::map<int, Fixture>;
  auto it = cache->find(entries);
  if (it != cache->end()) return it->second;
  Fixture& f = (*cache)[entries];
  std::vector<double> df(Vocabulary().NumWords());
  for (WordId w = 0; w < df.size(); ++w) df[w] = std::exp(-Vocabulary().Weight(w));
  std::discrete_distribution<WordId> word(df.begin(), df.end());
  std::mt19937_64 rng(1);
  for (int i = 0; i < entries; ++i) {
    f.entries.push_back(SampleImage(word, rng, 1000));
    if (!f.db.Add(i, f.entries.back()).ok()) std::abort();
  }
  for (int i = 0; i < 64; ++i) f.queries.push_back(SampleImage(word, rng, 1000));
  return f;
}

void BM_Transform(benchmark::State& state) {
  const cv::Mat descriptors = FrameDescriptors();
  const int level = static_cast<int>(state.range(0));
  size_t words = 0;
  for (auto _ : state) {
    FeatureVector features;
    StatusOr<BowVector> bow = level > 0 ? Vocabulary().Transform(descriptors, level, &features)
                                        : Vocabulary().Transform(descriptors);
    if (!bow.ok()) std::abort();
    words = bow->size();
    benchmark::DoNotOptimize(bow);
  }
  state.counters["descriptors"] = descriptors.rows;
  state.counters["words"] = static_cast<double>(words);
}
BENCHMARK(BM_Transform)->Arg(0)->Arg(2)->ArgName("feature_level")->Unit(benchmark::kMicrosecond);

void BM_Query(benchmark::State& state) {
  const Fixture& f = Database(static_cast<int>(state.range(0)));
  size_t i = 0;
  double postings = 0, scored = 0, n = 0;
  for (auto _ : state) {
    PlaceQueryStats stats;
    std::vector<PlaceMatch> m = f.db.Query(f.queries[i++ % f.queries.size()], 10, {}, &stats);
    benchmark::DoNotOptimize(m);
    postings += static_cast<double>(stats.postings_visited);
    scored += static_cast<double>(stats.entries_scored);
    ++n;
  }
  state.counters["postings"] = postings / n;
  state.counters["entries_scored"] = scored / n;
  state.counters["query_words"] = static_cast<double>(f.queries[0].size());
}
BENCHMARK(BM_Query)->Arg(100)->Arg(1000)->Arg(10000)->ArgName("entries")->Unit(
    benchmark::kMicrosecond);

void BM_BruteForce(benchmark::State& state) {
  const Fixture& f = Database(static_cast<int>(state.range(0)));
  size_t i = 0;
  for (auto _ : state) {
    const BowVector& q = f.queries[i++ % f.queries.size()];
    double best = 0;
    for (const BowVector& e : f.entries) best = std::max(best, BowVocabulary::Score(q, e));
    benchmark::DoNotOptimize(best);
  }
}
BENCHMARK(BM_BruteForce)
    ->Arg(100)
    ->Arg(1000)
    ->Arg(10000)
    ->ArgName("entries")
    ->Unit(benchmark::kMicrosecond);

}  // namespace
}  // namespace semmap

BENCHMARK_MAIN();
