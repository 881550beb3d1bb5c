#include "core/slam/place_database.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace semmap {

Status PlaceDatabase::Add(int64_t entry_id, const BowVector& bow) {
  if (slot_of_.contains(entry_id)) {
    return AlreadyExistsError("place entry " + std::to_string(entry_id) + " exists");
  }
  for (size_t i = 0; i < bow.size(); ++i) {
    if (i > 0 && bow[i].word <= bow[i - 1].word) {
      return InvalidArgumentError("BowVector words must be sorted and unique");
    }
    if (!std::isfinite(bow[i].weight) || bow[i].weight <= 0) {
      return InvalidArgumentError("BowVector weights must be positive and finite");
    }
  }
  uint32_t slot = 0;
  if (!free_slots_.empty()) {
    slot = free_slots_.back();
    free_slots_.pop_back();
  } else {
    slot = static_cast<uint32_t>(entries_.size());
    entries_.emplace_back();
  }
  Entry& entry = entries_[slot];
  entry.id = entry_id;
  entry.words.clear();
  entry.words.reserve(bow.size());
  for (const BowEntry& e : bow) {
    // Kept positive in float too: Query relies on every posting adding to the score.
    const float weight = std::max(static_cast<float>(e.weight), std::numeric_limits<float>::min());
    index_[e.word].push_back({slot, weight});
    entry.words.push_back(e.word);
  }
  num_postings_ += bow.size();
  slot_of_.emplace(entry_id, slot);
  return OkStatus();
}

Status PlaceDatabase::Remove(int64_t entry_id) {
  const auto it = slot_of_.find(entry_id);
  if (it == slot_of_.end()) {
    return NotFoundError("no place entry " + std::to_string(entry_id));
  }
  const uint32_t slot = it->second;
  Entry& entry = entries_[slot];
  for (WordId w : entry.words) {
    auto list = index_.find(w);
    std::vector<Posting>& postings = list->second;
    // Order within a list does not matter: swap the entry's posting out.
    const auto p = std::find_if(postings.begin(), postings.end(),
                                [slot](const Posting& q) { return q.slot == slot; });
    *p = postings.back();
    postings.pop_back();
    if (postings.empty()) index_.erase(list);
  }
  num_postings_ -= entry.words.size();
  entry.words = {};
  free_slots_.push_back(slot);
  slot_of_.erase(it);
  return OkStatus();
}

std::vector<PlaceMatch> PlaceDatabase::Query(const BowVector& query, int max_results,
                                             const std::function<bool(int64_t)>& exclude,
                                             PlaceQueryStats* stats) const {
  PlaceQueryStats local;
  std::vector<PlaceMatch> matches;
  if (max_results > 0 && !query.empty()) {
    // Zeroing the accumulator is one memset; everything else is per posting or per touched entry.
    std::vector<double> score(entries_.size(), 0.0);
    std::vector<uint32_t> touched;
    for (const BowEntry& q : query) {
      if (!(q.weight > 0)) continue;
      ++local.words;
      const auto list = index_.find(q.word);
      if (list == index_.end()) continue;
      local.postings_visited += static_cast<int64_t>(list->second.size());
      for (const Posting& p : list->second) {
        if (score[p.slot] == 0) touched.push_back(p.slot);  // weights are positive
        score[p.slot] += std::min(q.weight, static_cast<double>(p.weight));
      }
    }
    local.entries_scored = static_cast<int64_t>(touched.size());
    matches.reserve(touched.size());
    for (uint32_t slot : touched) {
      const int64_t id = entries_[slot].id;
      if (exclude && exclude(id)) continue;
      matches.push_back({id, std::clamp(score[slot], 0.0, 1.0)});
    }
    const auto better = [](const PlaceMatch& a, const PlaceMatch& b) {
      return a.score != b.score ? a.score > b.score : a.entry_id < b.entry_id;
    };
    const size_t keep = std::min(matches.size(), static_cast<size_t>(max_results));
    std::partial_sort(matches.begin(), matches.begin() + static_cast<long>(keep), matches.end(),
                      better);
    matches.resize(keep);
  }
  if (stats != nullptr) *stats = local;
  return matches;
}

size_t PlaceDatabase::HeldBytes() const {
  // A hash node: the value, the next pointer and the cached hash, rounded up by the allocator.
  constexpr size_t kHashNodeOverhead = 2 * sizeof(void*);
  size_t bytes =
      index_.bucket_count() * sizeof(void*) + slot_of_.bucket_count() * sizeof(void*) +
      slot_of_.size() * (sizeof(std::pair<const int64_t, uint32_t>) + kHashNodeOverhead) +
      entries_.capacity() * sizeof(Entry) + free_slots_.capacity() * sizeof(uint32_t);
  for (const auto& [word, postings] : index_) {
    bytes += sizeof(std::pair<const WordId, std::vector<Posting>>) + kHashNodeOverhead +
             postings.capacity() * sizeof(Posting);
  }
  for (const Entry& entry : entries_) bytes += entry.words.capacity() * sizeof(WordId);
  return bytes;
}

}  // namespace semmap
