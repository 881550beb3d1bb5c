// Vocabulary training: breadth-first hierarchical k-majority over all training descriptors,
// then IDF weights from the training images.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <random>
#include <utility>

#include "common/hamming.h"
#include "core/slam/bow_vocabulary.h"

namespace semmap {
namespace {

// All training descriptors, contiguous.
struct Descriptors {
  int bytes = 0;
  std::vector<uint8_t> data;
  const uint8_t* operator[](uint32_t i) const {
    return data.data() + static_cast<size_t>(i) * static_cast<size_t>(bytes);
  }
};

struct Split {
  std::vector<std::vector<uint32_t>> clusters;  // member indices, none empty
  std::vector<uint8_t> centres;                 // clusters.size() x bytes
};

uint64_t SplitMix64(uint64_t x) {
  x += 0x9E3779B97F4A7C15ULL;
  x = (x ^ (x >> 30)) * 0xBF58476D1CE4E5B9ULL;
  x = (x ^ (x >> 27)) * 0x94D049BB133111EBULL;
  return x ^ (x >> 31);
}

// Up to `limit` distinct descriptors among `members` (first occurrences, in order); stops
// looking once there are more than `limit`.
std::vector<uint32_t> DistinctUpTo(const Descriptors& d, const std::vector<uint32_t>& members,
                                   size_t limit) {
  std::vector<uint32_t> distinct;
  for (uint32_t m : members) {
    const bool seen = std::any_of(distinct.begin(), distinct.end(), [&](uint32_t x) {
      return std::memcmp(d[x], d[m], static_cast<size_t>(d.bytes)) == 0;
    });
    if (seen) continue;
    distinct.push_back(m);
    if (distinct.size() > limit) break;
  }
  return distinct;
}

// out[i] = min(d2[i], distance(member i, seed)^2); returns the sum of out.
SEMMAP_POPCNT_CLONES uint64_t MinSquaredDistances(const Descriptors& d,
                                                  const std::vector<uint32_t>& members,
                                                  const uint8_t* seed, const uint64_t* d2,
                                                  uint64_t* out) {
  uint64_t total = 0;
  for (size_t i = 0; i < members.size(); ++i) {
    const uint64_t h = static_cast<uint64_t>(HammingDistance(d[members[i]], seed, d.bytes));
    out[i] = std::min(d2[i], h * h);
    total += out[i];
  }
  return total;
}

// Greedy k-means++ seeding under the Hamming metric: each next seed is the best (lowest total
// squared distance to the nearest seed) of 2 + ln k candidates, each drawn with probability
// proportional to its squared distance to the nearest seed so far. Plain k-means++ often puts
// two seeds in one of several well-separated clusters; the greedy pick rarely does. Needs more
// than k distinct members, so every draw finds a member at non-zero distance.
std::vector<uint32_t> SeedKMeansPlusPlus(const Descriptors& d, const std::vector<uint32_t>& members,
                                         int k, std::mt19937_64& rng) {
  const size_t n = members.size();
  const int candidates = 2 + static_cast<int>(std::log(static_cast<double>(k)));
  std::vector<uint32_t> seeds = {members[rng() % n]};
  std::vector<uint64_t> d2(n, UINT64_MAX), trial(n), best_trial(n);
  uint64_t total = MinSquaredDistances(d, members, d[seeds[0]], d2.data(), d2.data());
  while (static_cast<int>(seeds.size()) < k && total > 0) {
    uint64_t best_total = UINT64_MAX;
    uint32_t best = 0;
    for (int c = 0; c < candidates; ++c) {
      uint64_t r = rng() % total;
      size_t pick = 0;
      while (r >= d2[pick]) r -= d2[pick++];
      const uint64_t potential =
          MinSquaredDistances(d, members, d[members[pick]], d2.data(), trial.data());
      if (potential < best_total) {
        best_total = potential;
        best = members[pick];
        best_trial.swap(trial);
      }
    }
    seeds.push_back(best);
    d2.swap(best_trial);
    total = best_total;
  }
  return seeds;
}

// Bitwise majority of each cluster (the Hamming-metric median); ties give 0.
void MajorityCentres(const Descriptors& d, const std::vector<uint32_t>& members,
                     const std::vector<int>& assignment, int k, std::vector<uint8_t>* centres) {
  const size_t bits = static_cast<size_t>(d.bytes) * 8;
  std::vector<uint32_t> ones(static_cast<size_t>(k) * bits, 0);
  std::vector<uint32_t> sizes(static_cast<size_t>(k), 0);
  for (size_t i = 0; i < members.size(); ++i) {
    const size_t c = static_cast<size_t>(assignment[i]);
    ++sizes[c];
    uint32_t* counts = ones.data() + c * bits;
    const uint8_t* x = d[members[i]];
    for (int b = 0; b < d.bytes; ++b) {
      const uint8_t v = x[b];
      for (int j = 0; j < 8; ++j) counts[b * 8 + j] += (v >> j) & 1u;
    }
  }
  for (size_t c = 0; c < static_cast<size_t>(k); ++c) {
    if (sizes[c] == 0) continue;  // keeps its old centre; dropped when still empty at the end
    uint8_t* out = centres->data() + c * static_cast<size_t>(d.bytes);
    const uint32_t* counts = ones.data() + c * bits;
    for (int b = 0; b < d.bytes; ++b) {
      uint8_t v = 0;
      for (int j = 0; j < 8; ++j) {
        if (2 * counts[b * 8 + j] > sizes[c]) v = static_cast<uint8_t>(v | (1u << j));
      }
      out[b] = v;
    }
  }
}

// Splits one node's members into at most k clusters. Fewer than two clusters means the node
// stays a leaf (all members equal).
Split SplitNode(const Descriptors& d, const std::vector<uint32_t>& members, int k,
                int max_iterations, uint64_t seed) {
  Split split;
  const size_t bytes = static_cast<size_t>(d.bytes);
  const std::vector<uint32_t> distinct = DistinctUpTo(d, members, static_cast<size_t>(k));
  if (distinct.size() <= static_cast<size_t>(k)) {
    // As many distinct descriptors as children at most: one child each, exact centres.
    split.clusters.resize(distinct.size());
    for (uint32_t m : members) {
      for (size_t c = 0; c < distinct.size(); ++c) {
        if (std::memcmp(d[distinct[c]], d[m], bytes) == 0) {
          split.clusters[c].push_back(m);
          break;
        }
      }
    }
    for (uint32_t x : distinct) split.centres.insert(split.centres.end(), d[x], d[x] + bytes);
    return split;
  }

  std::mt19937_64 rng(SplitMix64(seed));
  const std::vector<uint32_t> seeds = SeedKMeansPlusPlus(d, members, k, rng);
  const int clusters = static_cast<int>(seeds.size());
  std::vector<uint8_t> centres;
  for (uint32_t s : seeds) centres.insert(centres.end(), d[s], d[s] + bytes);
  std::vector<int> assignment(members.size(), -1);
  for (int iteration = 0; iteration < max_iterations; ++iteration) {
    bool changed = false;
    for (size_t i = 0; i < members.size(); ++i) {
      const int best = NearestCentre(d[members[i]], centres.data(), clusters, d.bytes);
      changed |= assignment[i] != best;
      assignment[i] = best;
    }
    if (!changed) break;  // the centres are already the medians of these clusters
    MajorityCentres(d, members, assignment, clusters, &centres);
  }

  std::vector<std::vector<uint32_t>> grouped(static_cast<size_t>(clusters));
  for (size_t i = 0; i < members.size(); ++i) {
    grouped[static_cast<size_t>(assignment[i])].push_back(members[i]);
  }
  for (size_t c = 0; c < grouped.size(); ++c) {
    if (grouped[c].empty()) continue;
    split.clusters.push_back(std::move(grouped[c]));
    const uint8_t* centre = centres.data() + c * bytes;
    split.centres.insert(split.centres.end(), centre, centre + bytes);
  }
  return split;
}

}  // namespace

StatusOr<BowVocabulary> BowVocabulary::Train(const std::vector<cv::Mat>& descriptor_sets,
                                             const BowTrainingOptions& options) {
  SEMMAP_RETURN_IF_ERROR(options.Validate());
  Descriptors d;
  int images = 0;
  for (size_t s = 0; s < descriptor_sets.size(); ++s) {
    const cv::Mat& set = descriptor_sets[s];
    if (set.empty()) continue;
    if (set.type() != CV_8UC1 || (d.bytes != 0 && set.cols != d.bytes)) {
      return InvalidArgumentError("descriptor set " + std::to_string(s) +
                                  " is not CV_8UC1 with the width of the first set (" +
                                  std::to_string(d.bytes) + " bytes)");
    }
    d.bytes = set.cols;
    for (int r = 0; r < set.rows; ++r) {
      d.data.insert(d.data.end(), set.ptr<uint8_t>(r), set.ptr<uint8_t>(r) + set.cols);
    }
    ++images;
  }
  if (images == 0) return InvalidArgumentError("no training descriptors");
  const size_t total = d.data.size() / static_cast<size_t>(d.bytes);
  if (total >= (size_t{1} << 32)) return InvalidArgumentError("too many training descriptors");

  BowVocabulary v;
  v.branching_ = options.branching;
  v.levels_ = options.levels;
  v.descriptor_bytes_ = d.bytes;
  v.training_images_ = images;
  v.nodes_.emplace_back();
  v.centres_.assign(static_cast<size_t>(d.bytes), 0);

  struct Pending {
    NodeId node;
    std::vector<uint32_t> members;
  };
  std::vector<Pending> level(1);
  level[0].members.resize(total);
  for (size_t i = 0; i < total; ++i) level[0].members[i] = static_cast<uint32_t>(i);
  // Breadth first, so nodes are numbered level by level with siblings contiguous.
  for (int depth = 0; depth < options.levels && !level.empty(); ++depth) {
    std::vector<Pending> next;
    for (Pending& p : level) {
      const uint64_t node_seed = options.seed ^ SplitMix64(p.node);
      Split split = SplitNode(d, p.members, options.branching, options.max_iterations, node_seed);
      p.members = {};
      if (split.clusters.size() < 2) continue;  // all members equal: a word above depth L
      v.nodes_[p.node].first_child = static_cast<uint32_t>(v.nodes_.size());
      v.nodes_[p.node].num_children = static_cast<uint32_t>(split.clusters.size());
      for (auto& cluster : split.clusters) {
        next.push_back({static_cast<NodeId>(v.nodes_.size()), std::move(cluster)});
        v.nodes_.emplace_back();
      }
      v.centres_.insert(v.centres_.end(), split.centres.begin(), split.centres.end());
    }
    if (options.progress) options.progress(depth + 1, next.size());
    level = std::move(next);
  }

  // Count the words so Finalize() can number them, then weigh them by the images they occur in.
  size_t leaves = 0;
  for (size_t i = 1; i < v.nodes_.size(); ++i) leaves += v.nodes_[i].num_children == 0;
  v.weights_.assign(leaves, 0.0);
  if (Status s = v.Finalize(); !s.ok())
    return InternalError("training built a bad tree: " + s.message());
  std::vector<uint32_t> images_with(leaves, 0);
  std::vector<int> last_image(leaves, -1);
  int image = 0;
  for (const cv::Mat& set : descriptor_sets) {
    if (set.empty()) continue;
    for (int r = 0; r < set.rows; ++r) {
      const WordId w = v.Quantize(set.ptr<uint8_t>(r));
      if (last_image[w] != image) last_image[w] = image, ++images_with[w];
    }
    ++image;
  }
  for (size_t w = 0; w < leaves; ++w) {
    // A word no training image reaches by descent is as rare as can be: weigh it as if seen once.
    v.weights_[w] = std::log(static_cast<double>(images) / std::max<uint32_t>(1, images_with[w]));
  }
  return v;
}

}  // namespace semmap
