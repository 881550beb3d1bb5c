// Vocabulary file reader (BowVocabulary::Deserialize, what Load reads; models/orb_vocab.bin).
// Each input is read twice: as it is (the SHA-256 trailer rejects almost every mutation), and
// with its trailer replaced by the digest of the rest, so mutations reach the parser and the
// tree checks. What loads re-serialises to the same bytes, and quantising descriptors with it
// gives L1-normalised vectors.
#include <cmath>
#include <cstdint>
#include <cstring>
#include <opencv2/core.hpp>
#include <string>

#include "common/sha256.h"
#include "core/slam/bow_vocabulary.h"
#include "tests/fuzz/fuzz_util.h"

namespace semmap {
namespace {

constexpr size_t kDigestBytes = 32;

void CheckBow(const BowVector& bow, const BowVocabulary& vocabulary) {
  double sum = 0;
  for (size_t i = 0; i < bow.size(); ++i) {
    FUZZ_CHECK(bow[i].word < vocabulary.NumWords());
    if (i > 0) FUZZ_CHECK(bow[i].word > bow[i - 1].word);
    FUZZ_CHECK(std::isfinite(bow[i].weight) && bow[i].weight > 0);
    sum += bow[i].weight;
  }
  if (!bow.empty()) {
    FUZZ_CHECK(std::abs(sum - 1.0) < 1e-9);
    FUZZ_CHECK(std::abs(BowVocabulary::Score(bow, bow) - 1.0) < 1e-9);
  }
}

void CheckLoaded(const BowVocabulary& v, std::string_view bytes) {
  FUZZ_CHECK(!v.empty());
  FUZZ_CHECK(v.Serialize() == bytes);
  // Descriptors from the input itself: the word centres, then the input's first bytes.
  const int width = v.descriptor_bytes();
  const int rows = static_cast<int>(std::min<size_t>(v.NumWords(), 16)) + 1;
  cv::Mat descriptors(rows, width, CV_8UC1, cv::Scalar(0));
  for (int r = 0; r + 1 < rows; ++r)
    v.WordDescriptor(static_cast<WordId>(r)).copyTo(descriptors.row(r));
  std::memcpy(descriptors.ptr<uint8_t>(rows - 1), bytes.data(),
              std::min<size_t>(bytes.size(), static_cast<size_t>(width)));
  for (int level = 0; level <= v.levels(); ++level) {
    FeatureVector features;
    StatusOr<BowVector> bow = v.Transform(descriptors, level, &features);
    FUZZ_CHECK(bow.ok());
    CheckBow(*bow, v);
    size_t grouped = 0;
    for (size_t i = 0; i < features.size(); ++i) {
      if (i > 0) FUZZ_CHECK(features[i].node > features[i - 1].node);
      FUZZ_CHECK(features[i].node < v.NumNodes());
      grouped += features[i].features.size();
    }
    FUZZ_CHECK(grouped == static_cast<size_t>(rows));
  }
  for (int r = 0; r + 1 < rows; ++r) {
    // A word's own centre quantises to a word at least as close (ties go to the first child).
    FUZZ_CHECK(v.Quantize(descriptors.ptr<uint8_t>(r)) < v.NumWords());
  }
}

}  // namespace
}  // namespace semmap

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace semmap;
  const std::string_view input = fuzz::AsText(data, size);
  StatusOr<BowVocabulary> as_is = BowVocabulary::Deserialize(input);
  if (as_is.ok()) CheckLoaded(*as_is, input);

  if (input.size() < kDigestBytes) return 0;
  std::string resealed(input.substr(0, input.size() - kDigestBytes));
  const Sha256Digest digest = Sha256(resealed);
  resealed.append(reinterpret_cast<const char*>(digest.data()), digest.size());
  StatusOr<BowVocabulary> v = BowVocabulary::Deserialize(resealed);
  if (!v.ok()) {
    const StatusCode code = v.status().code();
    FUZZ_CHECK(code == StatusCode::kInvalidArgument || code == StatusCode::kDataLoss);
    return 0;
  }
  CheckLoaded(*v, resealed);
  return 0;
}
