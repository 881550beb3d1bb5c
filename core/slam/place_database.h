// Place recognition database: an inverted index from vocabulary words to the entries
// (keyframes) whose BowVectors contain them. A query scores only the entries that share a word
// with it, by the L1 score of BowVocabulary::Score, accumulated word by word.
//
// Thread-compatible: const methods may run concurrently with each other, any mutation needs
// exclusive access (the SLAM back end owns it and calls it from its one thread).
#pragma once

#include <cstdint>
#include <functional>
#include <unordered_map>
#include <vector>

#include "common/status.h"
#include "core/slam/bow_vocabulary.h"

namespace semmap {

struct PlaceMatch {
  int64_t entry_id = 0;
  double score = 0;  // in [0, 1]
};

// What one query cost.
struct PlaceQueryStats {
  int64_t words = 0;             // query words looked up
  int64_t postings_visited = 0;  // (entry, weight) pairs read from the inverted lists
  int64_t entries_scored = 0;    // distinct entries sharing at least one word with the query
};

class PlaceDatabase {
 public:
  // `bow` as made by BowVocabulary::Transform (sorted, unique words, positive weights).
  // ALREADY_EXISTS for an id already present, INVALID_ARGUMENT for an unsorted or duplicate word
  // or a weight that is not positive and finite.
  Status Add(int64_t entry_id, const BowVector& bow);
  // NOT_FOUND when absent. Costs the total length of the entry's words' inverted lists.
  Status Remove(int64_t entry_id);
  bool Contains(int64_t entry_id) const { return slot_of_.contains(entry_id); }
  size_t size() const { return slot_of_.size(); }
  // Approximate heap bytes of the index (postings, entries' words, hash tables).
  size_t HeldBytes() const;

  // The best `max_results` entries by score, best first (ties by ascending id), skipping those
  // for which `exclude` (may be empty) returns true; entries sharing no word with the query are
  // never scored, never passed to `exclude` and never returned.
  std::vector<PlaceMatch> Query(const BowVector& query, int max_results,
                                const std::function<bool(int64_t)>& exclude = {},
                                PlaceQueryStats* stats = nullptr) const;

  // Total postings held (one per word of each entry).
  size_t NumPostings() const { return num_postings_; }

 private:
  struct Posting {
    uint32_t slot;
    float weight;  // float: halves the lists; scores need no more than 1e-7
  };
  struct Entry {
    int64_t id = 0;
    std::vector<WordId> words;  // for Remove
  };

  std::unordered_map<WordId, std::vector<Posting>> index_;
  std::vector<Entry> entries_;  // by slot; removed slots are reused
  std::vector<uint32_t> free_slots_;
  std::unordered_map<int64_t, uint32_t> slot_of_;
  size_t num_postings_ = 0;
};

}  // namespace semmap
