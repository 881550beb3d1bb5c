#include "core/slam/place_database.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <numeric>
#include <random>
#include <set>

namespace semmap {
namespace {

// `count` distinct random words in [first, first + range), random L1-normalised weights.
BowVector RandomBow(int count, WordId first, WordId range, std::mt19937_64& rng) {
  std::set<WordId> words;
  while (static_cast<int>(words.size()) < count) words.insert(first + rng() % range);
  BowVector bow;
  double total = 0;
  for (WordId w : words) {
    bow.push_back({w, 0.1 + static_cast<double>(rng() % 1000) / 1000.0});
    total += bow.back().weight;
  }
  for (BowEntry& e : bow) e.weight /= total;
  return bow;
}

bool Shares(const BowVector& a, const BowVector& b) {
  return std::any_of(a.begin(), a.end(), [&](const BowEntry& x) {
    return std::any_of(b.begin(), b.end(), [&](const BowEntry& y) { return x.word == y.word; });
  });
}

TEST(PlaceDatabaseTest, AnEntryIsItsOwnBestMatch) {
  std::mt19937_64 rng(1);
  PlaceDatabase db;
  std::vector<BowVector> bows;
  for (int i = 0; i < 300; ++i) {
    bows.push_back(RandomBow(60, 0, 2000, rng));
    ASSERT_TRUE(db.Add(1000 + i, bows.back()).ok());
  }
  EXPECT_EQ(db.size(), 300u);
  EXPECT_EQ(db.NumPostings(), 300u * 60u);
  for (int i = 0; i < 300; ++i) {
    const std::vector<PlaceMatch> m = db.Query(bows[static_cast<size_t>(i)], 3);
    ASSERT_EQ(m.size(), 3u);
    EXPECT_EQ(m[0].entry_id, 1000 + i);
    EXPECT_NEAR(m[0].score, 1.0, 1e-5);  // postings keep float weights
    EXPECT_GE(m[0].score, m[1].score);
    EXPECT_GE(m[1].score, m[2].score);
  }
}

TEST(PlaceDatabaseTest, ScoresAreTheVocabularyL1Score) {
  std::mt19937_64 rng(2);
  PlaceDatabase db;
  std::vector<BowVector> bows;
  for (int i = 0; i < 100; ++i) {
    bows.push_back(RandomBow(40, 0, 500, rng));
    ASSERT_TRUE(db.Add(i, bows.back()).ok());
  }
  const BowVector query = RandomBow(50, 0, 500, rng);
  const std::vector<PlaceMatch> m = db.Query(query, 1000);
  size_t sharing = 0;
  for (const BowVector& b : bows) sharing += Shares(query, b);
  ASSERT_EQ(m.size(), sharing);
  for (const PlaceMatch& match : m) {
    EXPECT_NEAR(match.score, BowVocabulary::Score(query, bows[static_cast<size_t>(match.entry_id)]),
                1e-6);
  }
}

TEST(PlaceDatabaseTest, EntriesSharingNoWordAreNeverScored) {
  std::mt19937_64 rng(3);
  PlaceDatabase db;
  // Ids 0..99 use words 0..999, ids 100..199 words 1000..1999.
  std::vector<BowVector> bows;
  for (int i = 0; i < 200; ++i) {
    bows.push_back(RandomBow(30, i < 100 ? 0 : 1000, 1000, rng));
    ASSERT_TRUE(db.Add(i, bows.back()).ok());
  }
  const BowVector query = RandomBow(20, 0, 1000, rng);
  int64_t sharing = 0;
  for (const BowVector& b : bows) sharing += Shares(query, b);
  std::set<int64_t> seen_by_exclude;
  PlaceQueryStats stats;
  const std::vector<PlaceMatch> m = db.Query(
      query, 1000,
      [&](int64_t id) {
        seen_by_exclude.insert(id);
        return false;
      },
      &stats);
  EXPECT_EQ(stats.words, 20);
  EXPECT_EQ(stats.entries_scored, sharing);
  EXPECT_LT(stats.entries_scored, 100);
  // About 20 words x 100 entries x 30 / 1000 words: only the lists of the query's words.
  EXPECT_LT(stats.postings_visited, 200);
  EXPECT_EQ(static_cast<int64_t>(seen_by_exclude.size()), sharing);
  for (int64_t id : seen_by_exclude) EXPECT_LT(id, 100);
  for (const PlaceMatch& match : m) EXPECT_LT(match.entry_id, 100);
  // A query from the other half touches none of the first.
  const std::vector<PlaceMatch> other = db.Query(RandomBow(20, 1000, 1000, rng), 1000, {}, &stats);
  for (const PlaceMatch& match : other) EXPECT_GE(match.entry_id, 100);
  // A query sharing nothing scores nothing.
  EXPECT_TRUE(db.Query({{5000, 1.0}}, 10, {}, &stats).empty());
  EXPECT_EQ(stats.entries_scored, 0);
  EXPECT_EQ(stats.postings_visited, 0);
}

TEST(PlaceDatabaseTest, ExcludeMaxResultsAndTies) {
  PlaceDatabase db;
  const BowVector same = {{1, 0.5}, {2, 0.5}};
  for (int64_t id : {9, 3, 5}) ASSERT_TRUE(db.Add(id, same).ok());
  ASSERT_TRUE(db.Add(4, {{1, 0.9}, {7, 0.1}}).ok());
  ASSERT_TRUE(db.Add(6, {{2, 0.2}, {8, 0.8}}).ok());
  const std::vector<PlaceMatch> all = db.Query(same, 10);
  ASSERT_EQ(all.size(), 5u);
  // Ties go to the lower id.
  EXPECT_EQ(all[0].entry_id, 3);
  EXPECT_EQ(all[1].entry_id, 5);
  EXPECT_EQ(all[2].entry_id, 9);
  EXPECT_EQ(all[3].entry_id, 4);
  EXPECT_NEAR(all[3].score, 0.5, 1e-7);
  EXPECT_EQ(all[4].entry_id, 6);
  EXPECT_NEAR(all[4].score, 0.2, 1e-7);
  const std::vector<PlaceMatch> odd =
      db.Query(same, 2, [](int64_t id) { return id == 3 || id % 2 == 0; });
  ASSERT_EQ(odd.size(), 2u);
  EXPECT_EQ(odd[0].entry_id, 5);
  EXPECT_EQ(odd[1].entry_id, 9);
  EXPECT_TRUE(db.Query(same, 0).empty());
  EXPECT_TRUE(db.Query({}, 10).empty());
}

TEST(PlaceDatabaseTest, AddAndRemove) {
  PlaceDatabase db;
  ASSERT_TRUE(db.Add(1, {{1, 0.5}, {2, 0.5}}).ok());
  EXPECT_EQ(db.Add(1, {{3, 1.0}}).code(), StatusCode::kAlreadyExists);
  EXPECT_EQ(db.Add(2, {{2, 0.5}, {1, 0.5}}).code(), StatusCode::kInvalidArgument);
  EXPECT_EQ(db.Add(2, {{1, 0.5}, {1, 0.5}}).code(), StatusCode::kInvalidArgument);
  EXPECT_EQ(db.Add(2, {{1, 0.0}}).code(), StatusCode::kInvalidArgument);
  EXPECT_EQ(db.Add(2, {{1, std::nan("")}}).code(), StatusCode::kInvalidArgument);
  EXPECT_FALSE(db.Contains(2));
  ASSERT_TRUE(db.Add(2, {{2, 0.5}, {3, 0.5}}).ok());
  ASSERT_TRUE(db.Add(3, {}).ok());  // an image with no weighted word: stored, never matched
  EXPECT_EQ(db.size(), 3u);
  EXPECT_EQ(db.NumPostings(), 4u);

  ASSERT_TRUE(db.Remove(1).ok());
  EXPECT_EQ(db.Remove(1).code(), StatusCode::kNotFound);
  EXPECT_FALSE(db.Contains(1));
  EXPECT_EQ(db.NumPostings(), 2u);
  std::vector<PlaceMatch> m = db.Query({{1, 0.5}, {2, 0.5}}, 10);
  ASSERT_EQ(m.size(), 1u);
  EXPECT_EQ(m[0].entry_id, 2);
  // The freed slot is reused by the next entry, which must not inherit the old postings.
  ASSERT_TRUE(db.Add(7, {{3, 1.0}}).ok());
  m = db.Query({{1, 1.0}}, 10);
  EXPECT_TRUE(m.empty());
  m = db.Query({{3, 1.0}}, 10);
  ASSERT_EQ(m.size(), 2u);
  EXPECT_EQ(m[0].entry_id, 7);
  EXPECT_NEAR(m[0].score, 1.0, 1e-7);
  EXPECT_EQ(m[1].entry_id, 2);
  ASSERT_TRUE(db.Remove(3).ok());
  ASSERT_TRUE(db.Remove(2).ok());
  ASSERT_TRUE(db.Remove(7).ok());
  EXPECT_EQ(db.size(), 0u);
  EXPECT_EQ(db.NumPostings(), 0u);
}

}  // namespace
}  // namespace semmap
