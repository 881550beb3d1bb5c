// The keyframe features a map's back end keeps in memory (a working memory, as RTAB-Map keeps
// its recent nodes and leaves the rest to the database). Every keyframe's features are in the
// store, as its session wrote them; in memory, within a byte budget, are those of the keyframes
// used most recently (a new keyframe is a use). Beyond the budget the least recently used give
// theirs back, and are read back from the store when loop verification, point fusion or a
// tracker's local map needs them again. Bundle adjustment needs none (each map-point observation
// carries its measurement), so a map's features cost at most the budget however many keyframes
// it grows to.
//
// The features live where they always did, in the graph's nodes (GraphKeyframe::features): a
// released node's pointer is null until Use() reads it back. Single-threaded: the back end's
// worker owns it, and releases only in Trim(), between keyframes, so a reference taken after
// Use() stays valid until then.
#pragma once

#include <cstdint>
#include <functional>
#include <utility>
#include <vector>

#include "common/map_types.h"
#include "common/status.h"
#include "core/slam/keyframe_graph.h"

namespace semmap {

class KeyframeFeatureMemory {
 public:
  // Reads the stored keyframes (session_id, seq) with their features, one answer per key in
  // order (one call for all: each call may wait behind the storage writer's queue).
  using Reader = std::function<std::vector<StatusOr<KeyframeRecord>>(
      const std::vector<std::pair<int64_t, int64_t>>& keys)>;

  // budget_bytes 0: nothing is ever released.
  KeyframeFeatureMemory(size_t budget_bytes, Reader reader)
      : budget_bytes_(budget_bytes), reader_(std::move(reader)) {}

  // Node `node` of `graph` holds its features (a new or restored keyframe): the most recent use.
  void Added(int node);

  // Makes the features of `nodes` (not culled) resident, reading the released ones back in one
  // call, and marks them used. Returns the nodes whose features could not be given (unreadable
  // in the store, or the store unreachable), with why: the caller leaves them out.
  std::vector<std::pair<int, Status>> Use(KeyframeGraph& graph, const std::vector<int>& nodes);

  // Releases the least recently used keyframes' features until the resident ones fit the budget.
  void Trim(KeyframeGraph& graph);

  // Heap bytes of the resident features (FrameFeatures::HeldBytes).
  size_t HeldBytes(const KeyframeGraph& graph) const;
  uint64_t released() const { return released_; }
  uint64_t read_back() const { return read_back_; }
  uint64_t unreadable() const { return unreadable_; }

 private:
  void Touch(int node);

  const size_t budget_bytes_;
  const Reader reader_;
  std::vector<uint64_t> last_use_;  // by node; larger is more recent
  uint64_t clock_ = 0;
  uint64_t released_ = 0, read_back_ = 0, unreadable_ = 0;
};

}  // namespace semmap
