#include "storage/map_store.h"

#include <algorithm>
#include <iterator>
#include <utility>

namespace semmap {
namespace {

template <typename T>
void MoveAppend(std::vector<T>& to, std::vector<T>&& from) {
  if (to.empty()) {
    to = std::move(from);  // steals the buffer: merging into an empty batch copies nothing
  } else {
    to.insert(to.end(), std::make_move_iterator(from.begin()), std::make_move_iterator(from.end()));
  }
  from.clear();
}

// Each entry replaces all of its map's rows, so of two for one map only the later one matters:
// it takes the earlier one's place instead of being written after it.
template <typename T>
void MergeReplacements(std::vector<std::pair<int64_t, std::vector<T>>>& to,
                       std::vector<std::pair<int64_t, std::vector<T>>>&& from) {
  for (auto& [map_id, rows] : from) {
    auto same_map = std::find_if(to.begin(), to.end(),
                                 [id = map_id](const auto& entry) { return entry.first == id; });
    if (same_map != to.end()) {
      same_map->second = std::move(rows);
    } else {
      to.emplace_back(map_id, std::move(rows));
    }
  }
  from.clear();
}

}  // namespace

void WriteBatch::Append(WriteBatch&& other) {
  MoveAppend(frames, std::move(other.frames));
  MoveAppend(keyframes, std::move(other.keyframes));
  MoveAppend(links, std::move(other.links));
  MoveAppend(blobs, std::move(other.blobs));
  MoveAppend(pose_updates, std::move(other.pose_updates));
  MoveAppend(culled_keyframes, std::move(other.culled_keyframes));
  MoveAppend(observations, std::move(other.observations));
  MergeReplacements(instances, std::move(other.instances));
  MergeReplacements(map_points, std::move(other.map_points));
}

}  // namespace semmap
