#include "core/slam/keyframe_feature_memory.h"

#include <algorithm>
#include <memory>
#include <string>

#include "core/slam/feature_codec.h"

namespace semmap {

void KeyframeFeatureMemory::Touch(int node) {
  if (node < 0) return;
  if (last_use_.size() <= static_cast<size_t>(node))
    last_use_.resize(static_cast<size_t>(node) + 1);
  last_use_[static_cast<size_t>(node)] = ++clock_;
}

void KeyframeFeatureMemory::Added(int node) { Touch(node); }

std::vector<std::pair<int, Status>> KeyframeFeatureMemory::Use(KeyframeGraph& graph,
                                                               const std::vector<int>& nodes) {
  std::vector<int> missing;
  for (int n : nodes) {
    if (n < 0 || n >= graph.size() || graph.node(n).culled) continue;
    Touch(n);
    if (!graph.node(n).features && std::find(missing.begin(), missing.end(), n) == missing.end()) {
      missing.push_back(n);
    }
  }
  std::vector<std::pair<int, Status>> failed;
  if (missing.empty()) return failed;
  std::vector<std::pair<int64_t, int64_t>> keys;
  keys.reserve(missing.size());
  for (int n : missing) keys.emplace_back(graph.node(n).session_id, graph.node(n).seq);
  std::vector<StatusOr<KeyframeRecord>> read =
      reader_ ? reader_(keys)
              : std::vector<StatusOr<KeyframeRecord>>(
                    keys.size(), FailedPreconditionError("no store to read features back from"));
  for (size_t i = 0; i < missing.size(); ++i) {
    const int n = missing[i];
    const std::string name = "features of keyframe seq " + std::to_string(keys[i].second) +
                             " of session " + std::to_string(keys[i].first);
    Status status = i < read.size() ? read[i].status() : InternalError("no answer from the store");
    if (status.ok() && read[i]->features.empty()) {
      status = NotFoundError("the store holds no features");
    }
    if (status.ok()) {
      StatusOr<FrameFeatures> decoded = DecodeFeatures(read[i]->features_format, read[i]->features);
      if (decoded.ok()) {
        graph.SetFeatures(n, std::make_shared<const FrameFeatures>(std::move(decoded).value()));
        ++read_back_;
        continue;
      }
      status = decoded.status();
    }
    ++unreadable_;
    failed.emplace_back(n, status.WithContext(name));
  }
  return failed;
}

void KeyframeFeatureMemory::Trim(KeyframeGraph& graph) {
  if (budget_bytes_ == 0) return;
  size_t held = 0;
  std::vector<std::pair<uint64_t, int>> resident;  // (last use, node)
  for (int n = 0; n < graph.size(); ++n) {
    const GraphKeyframe& k = graph.node(n);
    if (k.culled || !k.features) continue;
    held += k.features->HeldBytes();
    const uint64_t used =
        static_cast<size_t>(n) < last_use_.size() ? last_use_[static_cast<size_t>(n)] : 0;
    resident.emplace_back(used, n);
  }
  if (held <= budget_bytes_) return;
  std::sort(resident.begin(), resident.end());
  for (const auto& [used, n] : resident) {
    if (held <= budget_bytes_) break;
    held -= graph.node(n).features->HeldBytes();
    graph.SetFeatures(n, nullptr);
    ++released_;
  }
}

size_t KeyframeFeatureMemory::HeldBytes(const KeyframeGraph& graph) const {
  size_t held = 0;
  for (int n = 0; n < graph.size(); ++n) {
    const GraphKeyframe& k = graph.node(n);
    if (!k.culled && k.features) held += k.features->HeldBytes();
  }
  return held;
}

}  // namespace semmap
