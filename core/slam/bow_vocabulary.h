// Bag of binary words for place recognition: a hierarchical vocabulary tree over Hamming
// descriptors (ORB), after DBoW2 (Galvez-Lopez and Tardos, 2012). Each node splits its training
// descriptors into up to k clusters by k-majority (k-medians under the Hamming metric, greedy
// k-means++ seeding); the nodes at depth L (or clusters that cannot be split further) are the
// words. Images become sparse TF-IDF vectors compared by an L1 score; place_database.h indexes
// them.
#pragma once

#include <cstdint>
#include <functional>
#include <opencv2/core/mat.hpp>
#include <string>
#include <string_view>
#include <vector>

#include "common/status.h"

namespace semmap {

using WordId = uint32_t;
using NodeId = uint32_t;  // 0 is the root

struct BowEntry {
  WordId word = 0;
  double weight = 0;
  friend bool operator==(const BowEntry&, const BowEntry&) = default;
};

// An image's words: sorted by word id, no duplicates, positive weights summing to 1 (empty when
// no feature fell on a word with a non-zero weight).
using BowVector = std::vector<BowEntry>;

// Direct index: an image's features grouped by their vocabulary node at one level, so matching
// two images only compares features under the same node.
struct FeatureGroup {
  NodeId node = 0;
  std::vector<int> features;  // descriptor rows, ascending
  friend bool operator==(const FeatureGroup&, const FeatureGroup&) = default;
};
using FeatureVector = std::vector<FeatureGroup>;  // sorted by node

struct BowTrainingOptions {
  int branching = 10;  // k: children per node
  int levels = 4;      // L: depth of the words; at most k^L of them
  uint64_t seed = 1;   // k-means++ seeding: training is deterministic given the seed
  // k-majority rounds per node; a node stops earlier once no assignment changes.
  int max_iterations = 15;
  // Called after each level is split with (level, nodes at that level); may be empty.
  std::function<void(int level, size_t nodes)> progress;

  Status Validate() const;  // k 2..255, L 1..16, k^L <= 2^24, max_iterations >= 1
};

// Immutable once built: Transform, Quantize and Score may run on any number of threads.
class BowVocabulary {
 public:
  // An empty vocabulary: Transform fails with FAILED_PRECONDITION.
  BowVocabulary() = default;

  // Clusters all rows of all sets (CV_8UC1, one common width) and weights each word by
  // idf = log(N / n_w), N the non-empty sets (training images), n_w those containing the word.
  // INVALID_ARGUMENT for bad options, no descriptors, or sets of another type or width.
  static StatusOr<BowVocabulary> Train(const std::vector<cv::Mat>& descriptor_sets,
                                       const BowTrainingOptions& options);

  // Binary format: magic, version, k, L, descriptor bytes, nodes, word weights, SHA-256 of all
  // that. NOT_FOUND for a missing file, INVALID_ARGUMENT for another format or an unsupported
  // version, DATA_LOSS for a truncated or corrupted one, UNAVAILABLE when it cannot be read.
  static StatusOr<BowVocabulary> Load(const std::string& path);
  static StatusOr<BowVocabulary> Deserialize(std::string_view bytes);
  // Writes a temporary file next to `path` and renames it over `path`. UNAVAILABLE on I/O errors.
  Status Save(const std::string& path) const;
  std::string Serialize() const;

  // Words of an image's descriptors (CV_8UC1, descriptor_bytes() columns; no rows gives an
  // empty vector). INVALID_ARGUMENT for another type or width.
  StatusOr<BowVector> Transform(const cv::Mat& descriptors) const;
  // Also fills the direct index at `feature_level` (0 = root .. levels(); a feature whose word
  // is shallower than that is grouped under its word).
  StatusOr<BowVector> Transform(const cv::Mat& descriptors, int feature_level,
                                FeatureVector* features) const;

  // The word of one descriptor of descriptor_bytes() bytes: greedy descent from the root to the
  // nearest child centre (ties to the first child). The vocabulary must not be empty.
  WordId Quantize(const uint8_t* descriptor) const;

  // L1 similarity of two BowVectors, 1 - |a - b|_1 / 2 (DBoW2's L1 score): 1 for equal vectors,
  // 0 when they share no word. Computed as the sum over shared words of min(a_w, b_w), equal for
  // L1-normalised vectors and clamped to [0, 1].
  static double Score(const BowVector& a, const BowVector& b);

  bool empty() const { return word_node_.empty(); }
  int branching() const { return branching_; }
  int levels() const { return levels_; }
  int descriptor_bytes() const { return descriptor_bytes_; }
  int training_images() const { return training_images_; }
  size_t NumWords() const { return word_node_.size(); }
  size_t NumNodes() const { return nodes_.size(); }
  // Per word (word < NumWords()) or node (node < NumNodes()); unchecked.
  double Weight(WordId word) const { return weights_[word]; }
  NodeId WordNode(WordId word) const { return word_node_[word]; }
  int NodeLevel(NodeId node) const { return node_level_[node]; }  // the root is level 0
  // A word's centre as a 1 x descriptor_bytes() CV_8UC1 row (a copy).
  cv::Mat WordDescriptor(WordId word) const;

 private:
  struct Node {
    uint32_t first_child = 0;  // children are contiguous and come after their parent
    uint32_t num_children = 0;
  };

  const uint8_t* Centre(NodeId node) const {
    return centres_.data() + static_cast<size_t>(node) * static_cast<size_t>(descriptor_bytes_);
  }
  // The leaf of `descriptor` and its ancestor at `level` (or the leaf, if shallower).
  NodeId Descend(const uint8_t* descriptor, int level, NodeId* node_at_level) const;
  // Derives words and levels from nodes_ and checks the tree (a message for DATA_LOSS).
  Status Finalize();

  int branching_ = 0;
  int levels_ = 0;
  int descriptor_bytes_ = 0;
  int training_images_ = 0;
  std::vector<Node> nodes_;
  std::vector<uint8_t> centres_;  // nodes_.size() x descriptor_bytes_; the root's is unused
  std::vector<double> weights_;   // per word
  // Derived by Finalize().
  std::vector<NodeId> word_node_;
  std::vector<int32_t> node_word_;  // -1 for inner nodes
  std::vector<uint8_t> node_level_;
};

}  // namespace semmap
