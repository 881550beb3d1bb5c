// The vocabulary file: little-endian, checked end to end by a SHA-256 trailer.
//   magic "SMBOWVOC" | u32 version | u32 branching | u32 levels | u32 descriptor bytes
//   | u32 nodes | u32 words | u32 training images | u32 weighting (0 = TF-IDF)
//   | nodes x (u32 first child, u32 children) | nodes x descriptor bytes (centres)
//   | words x f64 idf (words are the childless nodes, in node order) | SHA-256 of all before it
#include <bit>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <optional>
#include <system_error>

#include "common/checked_math.h"
#include "common/sha256.h"
#include "core/slam/bow_vocabulary.h"

namespace semmap {
namespace {

constexpr std::string_view kVocabularyMagic = "SMBOWVOC";
constexpr uint32_t kVersion = 1;
constexpr uint32_t kWeightingTfIdf = 0;
constexpr size_t kVocabularyHeaderBytes = 8 + 8 * 4;
constexpr size_t kDigestBytes = 32;

void PutU32(std::string* out, uint32_t v) {
  for (int i = 0; i < 4; ++i) out->push_back(static_cast<char>((v >> (8 * i)) & 0xFF));
}

void PutF64(std::string* out, double v) {
  const uint64_t bits = std::bit_cast<uint64_t>(v);
  for (int i = 0; i < 8; ++i) out->push_back(static_cast<char>((bits >> (8 * i)) & 0xFF));
}

// Reads fields in order; the caller has checked the total size, so reads never run past it.
class VocabularyReader {
 public:
  explicit VocabularyReader(std::string_view bytes) : bytes_(bytes) {}
  uint32_t U32() {
    uint32_t v = 0;
    for (int i = 0; i < 4; ++i) v |= uint32_t{Byte()} << (8 * i);
    return v;
  }
  double F64() {
    uint64_t v = 0;
    for (int i = 0; i < 8; ++i) v |= uint64_t{Byte()} << (8 * i);
    return std::bit_cast<double>(v);
  }
  void Bytes(uint8_t* out, size_t n) {
    if (n == 0) return;  // `out` may be null then (an empty vector's data()): memcpy's UB
    std::memcpy(out, bytes_.data() + pos_, n);
    pos_ += n;
  }
  void Skip(size_t n) { pos_ += n; }

 private:
  uint8_t Byte() { return static_cast<uint8_t>(bytes_[pos_++]); }
  std::string_view bytes_;
  size_t pos_ = 0;
};

}  // namespace

std::string BowVocabulary::Serialize() const {
  std::string out(kVocabularyMagic);
  for (uint32_t v : {kVersion, static_cast<uint32_t>(branching_), static_cast<uint32_t>(levels_),
                     static_cast<uint32_t>(descriptor_bytes_), static_cast<uint32_t>(nodes_.size()),
                     static_cast<uint32_t>(word_node_.size()),
                     static_cast<uint32_t>(training_images_), kWeightingTfIdf}) {
    PutU32(&out, v);
  }
  for (const Node& n : nodes_) {
    PutU32(&out, n.first_child);
    PutU32(&out, n.num_children);
  }
  out.append(reinterpret_cast<const char*>(centres_.data()), centres_.size());
  for (double w : weights_) PutF64(&out, w);
  const Sha256Digest digest = Sha256(out);
  out.append(reinterpret_cast<const char*>(digest.data()), digest.size());
  return out;
}

StatusOr<BowVocabulary> BowVocabulary::Deserialize(std::string_view bytes) {
  if (bytes.size() < kVocabularyMagic.size()) {
    if (kVocabularyMagic.starts_with(bytes)) {
      return DataLossError("truncated vocabulary: " + std::to_string(bytes.size()) + " bytes");
    }
    return InvalidArgumentError("not a semmap vocabulary (no SMBOWVOC magic)");
  }
  if (!bytes.starts_with(kVocabularyMagic)) {
    return InvalidArgumentError("not a semmap vocabulary (no SMBOWVOC magic)");
  }
  if (bytes.size() < kVocabularyHeaderBytes + kDigestBytes) {
    return DataLossError("truncated vocabulary: " + std::to_string(bytes.size()) + " bytes");
  }
  // The checksum comes first: it also covers the version, so a damaged version reads as damage.
  const std::string_view body = bytes.substr(0, bytes.size() - kDigestBytes);
  const Sha256Digest digest = Sha256(body);
  if (std::memcmp(digest.data(), bytes.data() + body.size(), kDigestBytes) != 0) {
    return DataLossError("vocabulary checksum mismatch (truncated or corrupted file)");
  }
  VocabularyReader in(body);
  in.Skip(kVocabularyMagic.size());
  const uint32_t version = in.U32();
  if (version != kVersion) {
    return InvalidArgumentError("unsupported vocabulary version " + std::to_string(version) +
                                " (this build reads " + std::to_string(kVersion) + ")");
  }
  const uint32_t branching = in.U32(), levels = in.U32(), descriptor_bytes = in.U32();
  const uint32_t nodes = in.U32(), words = in.U32(), images = in.U32(), weighting = in.U32();
  if (weighting != kWeightingTfIdf) {
    return InvalidArgumentError("unsupported vocabulary weighting " + std::to_string(weighting));
  }
  // Checked: with 32-bit counts, nodes * (8 + descriptor bytes) + words * 8 can pass 2^64 and
  // wrap to a small size that a short file matches.
  const std::optional<uint64_t> tree_bytes = CheckedProduct({nodes, 8});
  const std::optional<uint64_t> centre_bytes = CheckedProduct({nodes, descriptor_bytes});
  const std::optional<uint64_t> weight_bytes = CheckedProduct({words, 8});
  std::optional<uint64_t> expected = kVocabularyHeaderBytes;
  for (const std::optional<uint64_t>& part : {tree_bytes, centre_bytes, weight_bytes}) {
    expected = expected && part ? CheckedAdd(*expected, *part) : std::nullopt;
  }
  if (!expected || *expected != body.size()) {
    return DataLossError("vocabulary size " + std::to_string(body.size()) + " does not match its " +
                         "header (" + (expected ? std::to_string(*expected) : "overflow") + ")");
  }
  if (branching > 255 || levels > 16 || descriptor_bytes > 4096 || images > (1u << 31)) {
    return DataLossError("implausible vocabulary header");
  }
  BowVocabulary v;
  v.branching_ = static_cast<int>(branching);
  v.levels_ = static_cast<int>(levels);
  v.descriptor_bytes_ = static_cast<int>(descriptor_bytes);
  v.training_images_ = static_cast<int>(images);
  v.nodes_.resize(nodes);
  for (Node& n : v.nodes_) {
    n.first_child = in.U32();
    n.num_children = in.U32();
  }
  v.centres_.resize(*centre_bytes);  // part of the body, which is in memory
  in.Bytes(v.centres_.data(), v.centres_.size());
  v.weights_.resize(words);
  for (double& w : v.weights_) w = in.F64();
  if (Status s = v.Finalize(); !s.ok()) return DataLossError("corrupt vocabulary: " + s.message());
  return v;
}

StatusOr<BowVocabulary> BowVocabulary::Load(const std::string& path) {
  std::error_code ec;
  if (!std::filesystem::exists(path, ec)) return NotFoundError("no vocabulary file " + path);
  if (!std::filesystem::is_regular_file(path, ec)) {
    return InvalidArgumentError(path + " is not a regular file");
  }
  std::ifstream file(path, std::ios::binary);
  std::string bytes;
  if (file) {
    bytes.assign(std::istreambuf_iterator<char>(file), std::istreambuf_iterator<char>());
  }
  if (!file && !file.eof()) return UnavailableError("cannot read " + path);
  StatusOr<BowVocabulary> v = Deserialize(bytes);
  if (!v.ok()) return v.status().WithContext(path);
  return v;
}

Status BowVocabulary::Save(const std::string& path) const {
  if (empty()) return FailedPreconditionError("cannot save an empty vocabulary");
  const std::string bytes = Serialize();
  const std::string tmp = path + ".tmp";
  {
    std::ofstream file(tmp, std::ios::binary | std::ios::trunc);
    file.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
    file.close();
    if (!file) {
      std::error_code ec;
      std::filesystem::remove(tmp, ec);
      return UnavailableError("cannot write " + tmp);
    }
  }
  std::error_code ec;
  std::filesystem::rename(tmp, path, ec);
  if (ec) {
    std::filesystem::remove(tmp, ec);
    return UnavailableError("cannot rename " + tmp + " to " + path + ": " + ec.message());
  }
  return OkStatus();
}

}  // namespace semmap
