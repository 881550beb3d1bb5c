#include "storage/map_store.h"

#include <iterator>

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

}  // namespace

void WriteBatch::Append(WriteBatch&& other) {
  MoveAppend(frames, std::move(other.frames));
  MoveAppend(keyframes, std::move(other.keyframes));
  MoveAppend(links, std::move(other.links));
  MoveAppend(blobs, std::move(other.blobs));
  MoveAppend(pose_updates, std::move(other.pose_updates));
}

}  // namespace semmap
