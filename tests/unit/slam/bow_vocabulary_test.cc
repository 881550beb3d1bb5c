#include "core/slam/bow_vocabulary.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <fstream>
#include <map>
#include <numeric>
#include <random>
#include <set>

#include "common/hamming.h"
#include "common/sha256.h"
#include "tests/testing/temp_dir.h"

namespace semmap {
namespace {

constexpr int kBytes = 32;

cv::Mat RandomDescriptors(int rows, std::mt19937_64& rng) {
  cv::Mat m(rows, kBytes, CV_8UC1);
  for (int r = 0; r < rows; ++r) {
    for (int c = 0; c < kBytes; ++c) m.at<uint8_t>(r, c) = static_cast<uint8_t>(rng());
  }
  return m;
}

// `centre` with `flips` distinct random bits inverted.
cv::Mat Perturbed(const cv::Mat& centre, int flips, std::mt19937_64& rng) {
  cv::Mat out = centre.clone();
  std::vector<int> bits(kBytes * 8);
  std::iota(bits.begin(), bits.end(), 0);
  std::shuffle(bits.begin(), bits.end(), rng);
  for (int i = 0; i < flips; ++i) out.at<uint8_t>(0, bits[i] / 8) ^= uint8_t(1u << (bits[i] % 8));
  return out;
}

int Distance(const cv::Mat& a, const cv::Mat& b) {
  return HammingDistance(a.ptr<uint8_t>(0), b.ptr<uint8_t>(0), kBytes);
}

BowVocabulary TrainOrDie(const std::vector<cv::Mat>& sets, const BowTrainingOptions& options) {
  StatusOr<BowVocabulary> v = BowVocabulary::Train(sets, options);
  EXPECT_TRUE(v.ok()) << v.status().ToString();
  return v.ok() ? std::move(v).value() : BowVocabulary();
}

BowTrainingOptions Options(int k, int levels, uint64_t seed = 1) {
  BowTrainingOptions o;
  o.branching = k;
  o.levels = levels;
  o.seed = seed;
  return o;
}

std::vector<cv::Mat> RandomSets(int sets, int rows, uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::vector<cv::Mat> out;
  out.reserve(sets);
  for (int i = 0; i < sets; ++i) out.push_back(RandomDescriptors(rows, rng));
  return out;
}

TEST(BowVocabularyTrainTest, RandomDescriptorsFillTheTree) {
  // 20 descriptors per leaf on average: every node splits into k, so exactly k^L words.
  const BowVocabulary v = TrainOrDie(RandomSets(20, 1000, 7), Options(10, 3));
  EXPECT_EQ(v.NumWords(), 1000u);
  EXPECT_EQ(v.NumNodes(), 1u + 10u + 100u + 1000u);
  EXPECT_EQ(v.branching(), 10);
  EXPECT_EQ(v.levels(), 3);
  EXPECT_EQ(v.descriptor_bytes(), kBytes);
  EXPECT_EQ(v.training_images(), 20);
  for (WordId w = 0; w < v.NumWords(); ++w) {
    ASSERT_EQ(v.NodeLevel(v.WordNode(w)), 3);
    // Random images share few words: no word is in all 20, so every idf is positive.
    ASSERT_GT(v.Weight(w), 0.0);
    ASSERT_LE(v.Weight(w), std::log(20.0) + 1e-12);
  }
}

TEST(BowVocabularyTrainTest, DeterministicForASeed) {
  const std::vector<cv::Mat> sets = RandomSets(10, 500, 3);
  const std::string a = TrainOrDie(sets, Options(6, 3, 42)).Serialize();
  const std::string b = TrainOrDie(sets, Options(6, 3, 42)).Serialize();
  const std::string c = TrainOrDie(sets, Options(6, 3, 43)).Serialize();
  EXPECT_EQ(ToHex(Sha256(a)), ToHex(Sha256(b)));
  EXPECT_NE(ToHex(Sha256(a)), ToHex(Sha256(c)));
}

TEST(BowVocabularyTrainTest, FewDistinctDescriptorsGiveOneWordEach) {
  // Five distinct descriptors (repeated) under k = 10: the root gets one child per descriptor and
  // each child, all of one descriptor, is a word at level 1 even though L = 3.
  std::mt19937_64 rng(5);
  const cv::Mat distinct = RandomDescriptors(5, rng);
  std::vector<cv::Mat> sets;
  for (int image = 0; image < 4; ++image) {
    cv::Mat set;
    for (int i = 0; i <= image; ++i) set.push_back(distinct.row(i));  // image j has 0..j
    set.push_back(distinct.row(4));
    sets.push_back(set);
  }
  const BowVocabulary v = TrainOrDie(sets, Options(10, 3));
  ASSERT_EQ(v.NumWords(), 5u);
  EXPECT_EQ(v.NumNodes(), 6u);
  std::set<WordId> words;
  for (int i = 0; i < 5; ++i) {
    const WordId w = v.Quantize(distinct.ptr<uint8_t>(i));
    words.insert(w);
    EXPECT_EQ(Distance(v.WordDescriptor(w), distinct.row(i)), 0);
    EXPECT_EQ(v.NodeLevel(v.WordNode(w)), 1);
  }
  EXPECT_EQ(words.size(), 5u);
  // idf = log(N / n_w) over the 4 images: row 0 and row 4 are in all of them, row 3 in one.
  EXPECT_DOUBLE_EQ(v.Weight(v.Quantize(distinct.ptr<uint8_t>(0))), 0.0);
  EXPECT_DOUBLE_EQ(v.Weight(v.Quantize(distinct.ptr<uint8_t>(4))), 0.0);
  EXPECT_DOUBLE_EQ(v.Weight(v.Quantize(distinct.ptr<uint8_t>(1))), std::log(4.0 / 3.0));
  EXPECT_DOUBLE_EQ(v.Weight(v.Quantize(distinct.ptr<uint8_t>(3))), std::log(4.0));
}

TEST(BowVocabularyTrainTest, RejectsBadInput) {
  const std::vector<cv::Mat> sets = RandomSets(2, 50, 1);
  EXPECT_EQ(BowVocabulary::Train(sets, Options(1, 3)).status().code(),
            StatusCode::kInvalidArgument);
  EXPECT_EQ(BowVocabulary::Train(sets, Options(10, 0)).status().code(),
            StatusCode::kInvalidArgument);
  EXPECT_EQ(BowVocabulary::Train(sets, Options(10, 8)).status().code(),
            StatusCode::kInvalidArgument);  // 10^8 words
  EXPECT_EQ(BowVocabulary::Train({}, Options(10, 3)).status().code(), StatusCode::kInvalidArgument);
  EXPECT_EQ(BowVocabulary::Train({cv::Mat(), cv::Mat()}, Options(10, 3)).status().code(),
            StatusCode::kInvalidArgument);
  std::vector<cv::Mat> mixed = sets;
  mixed.emplace_back(3, 16, CV_8UC1, cv::Scalar(0));
  EXPECT_EQ(BowVocabulary::Train(mixed, Options(10, 3)).status().code(),
            StatusCode::kInvalidArgument);
  EXPECT_EQ(BowVocabulary::Train({cv::Mat(3, 32, CV_32FC1)}, Options(10, 3)).status().code(),
            StatusCode::kInvalidArgument);
}

// 8 x 8 clusters in two levels: 8 random parent patterns, 8 children 16 bits from each parent,
// samples 2 bits from their child. The tree must find exactly this hierarchy (greedy k-means++
// seeding does for each of the training seeds 1..30; plain k-means++ often does not).
struct Hierarchy {
  std::vector<cv::Mat> children;  // 64 true centres
  std::vector<cv::Mat> images;
};

Hierarchy MakeHierarchy() {
  std::mt19937_64 rng(11);
  Hierarchy h;
  for (int p = 0; p < 8; ++p) {
    const cv::Mat parent = RandomDescriptors(1, rng);
    for (int c = 0; c < 8; ++c) h.children.push_back(Perturbed(parent, 16, rng));
  }
  // 40 images, each with 15 samples of 10 random clusters.
  for (int image = 0; image < 40; ++image) {
    cv::Mat set;
    for (int j = 0; j < 10; ++j) {
      const cv::Mat& child = h.children[rng() % h.children.size()];
      for (int s = 0; s < 15; ++s) set.push_back(Perturbed(child, 2, rng));
    }
    h.images.push_back(set);
  }
  return h;
}

TEST(BowVocabularyTest, RecoversHierarchicalClusters) {
  const Hierarchy h = MakeHierarchy();
  const BowVocabulary v = TrainOrDie(h.images, Options(8, 2));
  ASSERT_EQ(v.NumWords(), 64u);
  // Every true centre has its own word, whose centre is the true one within a bit or two.
  std::set<WordId> words;
  for (const cv::Mat& child : h.children) {
    const WordId w = v.Quantize(child.ptr<uint8_t>(0));
    words.insert(w);
    EXPECT_LE(Distance(v.WordDescriptor(w), child), 2);
  }
  EXPECT_EQ(words.size(), 64u);
  // A descriptor equal to a word's centre descends to that word.
  for (WordId w = 0; w < v.NumWords(); ++w) {
    const cv::Mat centre = v.WordDescriptor(w);
    EXPECT_EQ(v.Quantize(centre.ptr<uint8_t>(0)), w);
  }
}

TEST(BowVocabularyTest, TransformIsSortedNormalisedTfIdf) {
  const Hierarchy h = MakeHierarchy();
  const BowVocabulary v = TrainOrDie(h.images, Options(8, 2));
  const cv::Mat& descriptors = h.images[0];
  StatusOr<BowVector> bow = v.Transform(descriptors);
  ASSERT_TRUE(bow.ok()) << bow.status().ToString();
  ASSERT_FALSE(bow->empty());
  // Recompute by hand: count * idf per word, L1-normalised.
  std::map<WordId, double> expected;
  for (int r = 0; r < descriptors.rows; ++r) {
    const WordId w = v.Quantize(descriptors.ptr<uint8_t>(r));
    expected[w] += v.Weight(w);
  }
  double total = 0;
  for (auto& [w, x] : expected) total += x;
  ASSERT_EQ(bow->size(), expected.size());
  double sum = 0;
  for (size_t i = 0; i < bow->size(); ++i) {
    if (i > 0) {
      EXPECT_LT((*bow)[i - 1].word, (*bow)[i].word);
    }
    EXPECT_NEAR((*bow)[i].weight, expected[(*bow)[i].word] / total, 1e-12);
    sum += (*bow)[i].weight;
  }
  EXPECT_NEAR(sum, 1.0, 1e-12);
  EXPECT_NEAR(BowVocabulary::Score(*bow, *bow), 1.0, 1e-12);
}

TEST(BowVocabularyTest, FeatureVectorGroupsByNodeAtLevel) {
  const Hierarchy h = MakeHierarchy();
  const BowVocabulary v = TrainOrDie(h.images, Options(8, 2));
  const cv::Mat& descriptors = h.images[1];
  for (int level : {0, 1, 2}) {
    FeatureVector fv;
    ASSERT_TRUE(v.Transform(descriptors, level, &fv).ok());
    size_t features = 0;
    std::set<WordId> words;
    for (size_t g = 0; g < fv.size(); ++g) {
      if (g > 0) {
        EXPECT_LT(fv[g - 1].node, fv[g].node);
      }
      EXPECT_EQ(v.NodeLevel(fv[g].node), level);
      EXPECT_TRUE(std::is_sorted(fv[g].features.begin(), fv[g].features.end()));
      features += fv[g].features.size();
      for (int row : fv[g].features) {
        const WordId w = v.Quantize(descriptors.ptr<uint8_t>(row));
        words.insert(w);
        // At the word level the group's node is the feature's word.
        if (level == 2) {
          EXPECT_EQ(v.WordNode(w), fv[g].node);
        }
      }
    }
    EXPECT_EQ(features, static_cast<size_t>(descriptors.rows));
    if (level == 0) {
      EXPECT_EQ(fv.size(), 1u);
    }
    // The image's words lie under at most 8 parents.
    if (level == 1) {
      EXPECT_LE(fv.size(), 8u);
    }
    if (level == 2) {
      EXPECT_EQ(fv.size(), words.size());
    }
  }
  FeatureVector fv;
  EXPECT_EQ(v.Transform(descriptors, 3, &fv).status().code(), StatusCode::kInvalidArgument);
}

TEST(BowVocabularyTest, TransformRejectsWrongDescriptors) {
  const BowVocabulary v = TrainOrDie(RandomSets(4, 100, 2), Options(4, 2));
  StatusOr<BowVector> none = v.Transform(cv::Mat());
  ASSERT_TRUE(none.ok());
  EXPECT_TRUE(none->empty());
  EXPECT_EQ(v.Transform(cv::Mat(5, 32, CV_32FC1, cv::Scalar(0))).status().code(),
            StatusCode::kInvalidArgument);
  EXPECT_EQ(v.Transform(cv::Mat(5, 61, CV_8UC1, cv::Scalar(0))).status().code(),
            StatusCode::kInvalidArgument);
  EXPECT_EQ(BowVocabulary().Transform(cv::Mat(5, 32, CV_8UC1)).status().code(),
            StatusCode::kFailedPrecondition);
}

TEST(BowVocabularyTest, ScoreIsOneMinusHalfTheL1Distance) {
  const BowVector a = {{1, 0.5}, {4, 0.25}, {9, 0.25}};
  const BowVector b = {{1, 0.2}, {5, 0.3}, {9, 0.5}};
  const BowVector c = {{2, 0.6}, {3, 0.4}};
  // |a - b|_1 = 0.3 + 0.25 + 0.3 + 0.25 = 1.1.
  EXPECT_NEAR(BowVocabulary::Score(a, b), 1 - 1.1 / 2, 1e-12);
  EXPECT_NEAR(BowVocabulary::Score(b, a), BowVocabulary::Score(a, b), 1e-15);
  EXPECT_DOUBLE_EQ(BowVocabulary::Score(a, a), 1.0);
  EXPECT_DOUBLE_EQ(BowVocabulary::Score(a, c), 0.0);
  EXPECT_DOUBLE_EQ(BowVocabulary::Score(a, {}), 0.0);
}

// --- File format ---

void WriteFile(const std::string& path, std::string_view bytes) {
  std::ofstream(path, std::ios::binary | std::ios::trunc)
      .write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
}

TEST(BowVocabularyFileTest, SaveLoadRoundTripGivesIdenticalTransforms) {
  const std::vector<cv::Mat> sets = RandomSets(10, 300, 9);
  const BowVocabulary v = TrainOrDie(sets, Options(5, 3));
  testing::TempDir dir;
  ASSERT_TRUE(v.Save(dir.File("v.bin")).ok());
  StatusOr<BowVocabulary> loaded = BowVocabulary::Load(dir.File("v.bin"));
  ASSERT_TRUE(loaded.ok()) << loaded.status().ToString();
  EXPECT_EQ(loaded->NumWords(), v.NumWords());
  EXPECT_EQ(loaded->NumNodes(), v.NumNodes());
  EXPECT_EQ(loaded->training_images(), 10);
  EXPECT_EQ(loaded->Serialize(), v.Serialize());
  std::mt19937_64 rng(99);
  const cv::Mat probe = RandomDescriptors(500, rng);
  for (const cv::Mat& d : {probe, sets[3]}) {
    FeatureVector fa, fb;
    StatusOr<BowVector> a = v.Transform(d, 2, &fa), b = loaded->Transform(d, 2, &fb);
    ASSERT_TRUE(a.ok() && b.ok());
    EXPECT_EQ(*a, *b);  // bit-identical weights
    EXPECT_EQ(fa, fb);
  }
}

class CorruptFileTest : public ::testing::Test {
 protected:
  void SetUp() override {
    vocabulary_ = TrainOrDie(RandomSets(6, 200, 4), Options(4, 3));
    bytes_ = vocabulary_.Serialize();
  }
  StatusCode LoadCode(std::string_view bytes) {
    WriteFile(dir_.File("v.bin"), bytes);
    return BowVocabulary::Load(dir_.File("v.bin")).status().code();
  }
  testing::TempDir dir_;
  BowVocabulary vocabulary_;
  std::string bytes_;
};

TEST_F(CorruptFileTest, TruncatedIsDataLoss) {
  for (size_t length : {size_t{0}, size_t{3}, size_t{8}, size_t{20}, size_t{40}, size_t{72},
                        bytes_.size() / 2, bytes_.size() - 33, bytes_.size() - 1}) {
    EXPECT_EQ(LoadCode(bytes_.substr(0, length)), StatusCode::kDataLoss) << length << " bytes";
  }
  EXPECT_EQ(LoadCode(bytes_ + "x"), StatusCode::kDataLoss) << "trailing byte";
}

TEST_F(CorruptFileTest, BitFlipIsDataLoss) {
  // Every byte after the magic, one flipped bit at a time (a sample of positions for speed).
  for (size_t pos = 8; pos < bytes_.size(); pos += pos < 200 ? 1 : 97) {
    std::string damaged = bytes_;
    damaged[pos] = static_cast<char>(damaged[pos] ^ (1 << (pos % 8)));
    ASSERT_EQ(BowVocabulary::Deserialize(damaged).status().code(), StatusCode::kDataLoss)
        << "bit flip at byte " << pos;
  }
  std::string last = bytes_;
  last.back() = static_cast<char>(last.back() ^ 0x80);
  EXPECT_EQ(LoadCode(last), StatusCode::kDataLoss);
}

TEST_F(CorruptFileTest, ForeignFileIsInvalidArgument) {
  EXPECT_EQ(LoadCode(std::string("\x89PNG\r\n\x1a\n", 8) + std::string(100, '\0')),
            StatusCode::kInvalidArgument);
  EXPECT_EQ(LoadCode("# DBoW2 text vocabulary\n10 6 0 0\n"), StatusCode::kInvalidArgument);
  EXPECT_EQ(LoadCode("x"), StatusCode::kInvalidArgument);
  std::string magic_flip = bytes_;
  magic_flip[0] ^= 1;
  EXPECT_EQ(LoadCode(magic_flip), StatusCode::kInvalidArgument);
}

TEST_F(CorruptFileTest, OtherVersionIsInvalidArgument) {
  // A well-formed file of version 2 (checksum recomputed): not ours to read, not damage.
  std::string v2 = bytes_.substr(0, bytes_.size() - 32);
  v2[8] = 2;
  const Sha256Digest digest = Sha256(v2);
  v2.append(reinterpret_cast<const char*>(digest.data()), digest.size());
  EXPECT_EQ(LoadCode(v2), StatusCode::kInvalidArgument);
}

TEST_F(CorruptFileTest, InconsistentTreeWithAValidChecksumIsDataLoss) {
  // Node 0's first child pointed at itself, checksum recomputed: structure checks catch it.
  std::string bad = bytes_.substr(0, bytes_.size() - 32);
  std::fill(bad.begin() + 40, bad.begin() + 44, '\0');
  const Sha256Digest digest = Sha256(bad);
  bad.append(reinterpret_cast<const char*>(digest.data()), digest.size());
  EXPECT_EQ(LoadCode(bad), StatusCode::kDataLoss);
}

// `body` (a file without its digest) with a valid SHA-256 trailer.
std::string Sealed(std::string body) {
  const Sha256Digest digest = Sha256(body);
  body.append(reinterpret_cast<const char*>(digest.data()), digest.size());
  return body;
}

void PutU32At(std::string& bytes, size_t offset, uint32_t v) {
  for (int i = 0; i < 4; ++i) bytes[offset + i] = static_cast<char>((v >> (8 * i)) & 0xFF);
}

// Overflow edge of the size check: nodes 2^32 - 1 and descriptor bytes 2^32 - 7 make
// nodes * (8 + bytes) = 2^64 - 1, so with one word the announced size wraps to 47 bytes, the
// body given. Checked, it is an overflow, not a match.
TEST_F(CorruptFileTest, SizeThatWrapsPast2To64IsDataLoss) {
  std::string body = bytes_.substr(0, 40);  // magic + header
  PutU32At(body, 20, 0xFFFFFFF9u);          // descriptor bytes
  PutU32At(body, 24, 0xFFFFFFFFu);          // nodes
  PutU32At(body, 28, 1);                    // words
  body.resize(47, '\0');
  const Status s = BowVocabulary::Deserialize(Sealed(body)).status();
  EXPECT_EQ(s.code(), StatusCode::kDataLoss);
  EXPECT_NE(s.message().find("does not match its header (overflow)"), std::string::npos)
      << s.message();
}

// Found by fuzz_bow_vocabulary (UBSan): a header with no nodes (or 0-byte descriptors) copied
// its 0 centre bytes with memcpy into an empty vector's data(), a null pointer.
TEST_F(CorruptFileTest, NoCentreBytesIsDataLoss) {
  std::string body = bytes_.substr(0, 40);
  PutU32At(body, 24, 0);  // nodes
  PutU32At(body, 28, 0);  // words
  EXPECT_EQ(BowVocabulary::Deserialize(Sealed(body)).status().code(), StatusCode::kDataLoss);
  body = bytes_.substr(0, 40);
  PutU32At(body, 20, 0);  // descriptor bytes
  PutU32At(body, 24, 2);  // nodes
  PutU32At(body, 28, 1);  // words
  body += std::string(2 * 8 + 8, '\0');
  EXPECT_EQ(BowVocabulary::Deserialize(Sealed(body)).status().code(), StatusCode::kDataLoss);
}

// Found by fuzz_bow_vocabulary (a resealed file): word weights of 1e210 and 2e-319 loaded, and
// Transform gave a BowVector whose normalised weights were 0, not "positive, summing to 1".
// Weights are idf = log(N / n_w) in [0, log N]; others are damage.
TEST_F(CorruptFileTest, WeightsThatAreNoIdfAreDataLoss) {
  const std::string body = bytes_.substr(0, bytes_.size() - 32);
  const size_t last_weight = body.size() - 8;
  const double max_idf = std::log(static_cast<double>(vocabulary_.training_images()));
  for (const double w : {1e210, max_idf * 1.001, 2.29785e-319, -1.0}) {
    std::string bad = body;
    uint64_t bits = 0;
    std::memcpy(&bits, &w, sizeof(bits));
    for (int i = 0; i < 8; ++i) bad[last_weight + i] = static_cast<char>((bits >> (8 * i)) & 0xFF);
    const Status s = BowVocabulary::Deserialize(Sealed(bad)).status();
    EXPECT_EQ(s.code(), StatusCode::kDataLoss) << w;
  }
  std::string edge = body;  // exactly log N (a word in one training image) loads
  uint64_t bits = 0;
  std::memcpy(&bits, &max_idf, sizeof(bits));
  for (int i = 0; i < 8; ++i) edge[last_weight + i] = static_cast<char>((bits >> (8 * i)) & 0xFF);
  EXPECT_TRUE(BowVocabulary::Deserialize(Sealed(edge)).ok());
}

TEST_F(CorruptFileTest, MissingFileIsNotFound) {
  EXPECT_EQ(BowVocabulary::Load(dir_.File("absent.bin")).status().code(), StatusCode::kNotFound);
  EXPECT_EQ(BowVocabulary::Load(dir_.path()).status().code(), StatusCode::kInvalidArgument);
  EXPECT_EQ(vocabulary_.Save(dir_.File("no/such/dir/v.bin")).code(), StatusCode::kUnavailable);
  EXPECT_EQ(BowVocabulary().Save(dir_.File("empty.bin")).code(), StatusCode::kFailedPrecondition);
}

}  // namespace
}  // namespace semmap
