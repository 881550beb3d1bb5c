// The vocabulary tree at run time: quantisation, TF-IDF vectors, scores and tree checks.
// Training is in bow_training.cc, the file format in bow_vocabulary_io.cc.
#include "core/slam/bow_vocabulary.h"

#include <algorithm>
#include <cmath>
#include <utility>

#include "common/hamming.h"

namespace semmap {

Status BowTrainingOptions::Validate() const {
  if (branching < 2 || branching > 255) {
    return InvalidArgumentError("branching must be in 2..255, got " + std::to_string(branching));
  }
  if (levels < 1 || levels > 16) {
    return InvalidArgumentError("levels must be in 1..16, got " + std::to_string(levels));
  }
  // Bounds the node arrays (about 40 bytes a node for ORB).
  constexpr double kMaxWords = 1 << 24;
  if (std::pow(static_cast<double>(branching), levels) > kMaxWords) {
    return InvalidArgumentError("branching^levels must be at most 2^24 words");
  }
  if (max_iterations < 1) {
    return InvalidArgumentError("max_iterations must be positive, got " +
                                std::to_string(max_iterations));
  }
  return OkStatus();
}

NodeId BowVocabulary::Descend(const uint8_t* descriptor, int level, NodeId* node_at_level) const {
  NodeId node = 0;
  int depth = 0;
  if (node_at_level != nullptr && level == 0) *node_at_level = 0;
  while (nodes_[node].num_children > 0) {
    const Node& n = nodes_[node];
    node = n.first_child +
           static_cast<NodeId>(NearestCentre(descriptor, Centre(n.first_child),
                                             static_cast<int>(n.num_children), descriptor_bytes_));
    if (node_at_level != nullptr && ++depth == level) *node_at_level = node;
  }
  if (node_at_level != nullptr && depth < level) *node_at_level = node;
  return node;
}

WordId BowVocabulary::Quantize(const uint8_t* descriptor) const {
  return static_cast<WordId>(node_word_[Descend(descriptor, 0, nullptr)]);
}

StatusOr<BowVector> BowVocabulary::Transform(const cv::Mat& descriptors) const {
  return Transform(descriptors, 0, nullptr);
}

StatusOr<BowVector> BowVocabulary::Transform(const cv::Mat& descriptors, int feature_level,
                                             FeatureVector* features) const {
  if (empty()) return FailedPreconditionError("the vocabulary is empty");
  if (feature_level < 0 || feature_level > levels_) {
    return InvalidArgumentError("feature_level must be in 0.." + std::to_string(levels_) +
                                ", got " + std::to_string(feature_level));
  }
  if (features != nullptr) features->clear();
  if (descriptors.empty()) return BowVector{};
  if (descriptors.type() != CV_8UC1 || descriptors.cols != descriptor_bytes_) {
    return InvalidArgumentError("descriptors must be CV_8UC1 with " +
                                std::to_string(descriptor_bytes_) + " columns, got type " +
                                std::to_string(descriptors.type()) + " with " +
                                std::to_string(descriptors.cols));
  }
  const int rows = descriptors.rows;
  std::vector<WordId> words(static_cast<size_t>(rows));
  std::vector<std::pair<NodeId, int>> node_features;
  if (features != nullptr) node_features.reserve(static_cast<size_t>(rows));
  for (int r = 0; r < rows; ++r) {
    NodeId at_level = 0;
    const NodeId leaf =
        Descend(descriptors.ptr<uint8_t>(r), feature_level, features ? &at_level : nullptr);
    words[static_cast<size_t>(r)] = static_cast<WordId>(node_word_[leaf]);
    if (features != nullptr) node_features.emplace_back(at_level, r);
  }

  // TF-IDF: each occurrence adds the word's idf; the 1/n of TF cancels in the L1 normalisation.
  std::sort(words.begin(), words.end());
  BowVector bow;
  double total = 0;
  for (size_t i = 0; i < words.size();) {
    size_t j = i;
    while (j < words.size() && words[j] == words[i]) ++j;
    const double weight = static_cast<double>(j - i) * weights_[words[i]];
    if (weight > 0) {  // a word in every training image carries no information
      bow.push_back({words[i], weight});
      total += weight;
    }
    i = j;
  }
  for (BowEntry& e : bow) e.weight /= total;

  if (features != nullptr) {
    std::sort(node_features.begin(), node_features.end());
    for (const auto& [node, row] : node_features) {
      if (features->empty() || features->back().node != node) features->push_back({node, {}});
      features->back().features.push_back(row);
    }
  }
  return bow;
}

double BowVocabulary::Score(const BowVector& a, const BowVector& b) {
  // For non-negative vectors of L1 norm 1, 1 - |a - b|_1 / 2 = sum over shared words of min.
  double score = 0;
  auto i = a.begin(), j = b.begin();
  while (i != a.end() && j != b.end()) {
    if (i->word < j->word) {
      ++i;
    } else if (j->word < i->word) {
      ++j;
    } else {
      score += std::min(i->weight, j->weight);
      ++i, ++j;
    }
  }
  return std::clamp(score, 0.0, 1.0);
}

cv::Mat BowVocabulary::WordDescriptor(WordId word) const {
  cv::Mat row(1, descriptor_bytes_, CV_8UC1);
  std::copy_n(Centre(word_node_[word]), descriptor_bytes_, row.ptr<uint8_t>(0));
  return row;
}

Status BowVocabulary::Finalize() {
  const size_t n = nodes_.size();
  if (branching_ < 2 || levels_ < 1 || descriptor_bytes_ < 1) {
    return DataLossError("bad header: branching " + std::to_string(branching_) + ", levels " +
                         std::to_string(levels_) + ", descriptor bytes " +
                         std::to_string(descriptor_bytes_));
  }
  if (n < 2 || centres_.size() != n * static_cast<size_t>(descriptor_bytes_)) {
    return DataLossError("the tree has no words");
  }
  // Every node but the root must be the child of exactly one earlier node, so one pass in index
  // order sees each parent before its children.
  std::vector<uint8_t> covered(n, 0);
  node_level_.assign(n, 0);
  node_word_.assign(n, -1);
  word_node_.clear();
  for (size_t i = 0; i < n; ++i) {
    if (i > 0 && covered[i] != 1) {
      return DataLossError("node " + std::to_string(i) + " has no parent");
    }
    const Node& node = nodes_[i];
    if (node.num_children == 0) {
      if (i == 0) return DataLossError("the root has no children");
      node_word_[i] = static_cast<int32_t>(word_node_.size());
      word_node_.push_back(static_cast<NodeId>(i));
      continue;
    }
    const uint64_t end = uint64_t{node.first_child} + node.num_children;
    if (node.num_children > static_cast<uint32_t>(branching_) || node.first_child <= i || end > n ||
        node_level_[i] >= levels_) {
      return DataLossError("node " + std::to_string(i) + " has bad children");
    }
    for (uint64_t c = node.first_child; c < end; ++c) {
      if (covered[c]++ != 0) return DataLossError("node " + std::to_string(c) + " has 2 parents");
      node_level_[c] = static_cast<uint8_t>(node_level_[i] + 1);
    }
  }
  if (weights_.size() != word_node_.size()) {
    return DataLossError(std::to_string(weights_.size()) + " weights for " +
                         std::to_string(word_node_.size()) + " words");
  }
  // idf = log(N / n_w) with 1 <= n_w <= N lies in [0, log N]. A larger weight, or a subnormal
  // one (normalising a BowVector could round it to 0, breaking "positive weights summing to
  // 1"; a huge one makes the sum infinite), did not come from training.
  const double max_weight =
      std::log(static_cast<double>(std::max(training_images_, 1))) * (1 + 1e-9);
  for (double w : weights_) {
    if (!std::isfinite(w) || w < 0) return DataLossError("a word weight is negative or not finite");
    if (w > max_weight || std::fpclassify(w) == FP_SUBNORMAL) {
      return DataLossError("word weight " + std::to_string(w) + " is not an idf of " +
                           std::to_string(training_images_) + " training images");
    }
  }
  return OkStatus();
}

}  // namespace semmap
