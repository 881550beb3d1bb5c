#include "storage/sqlite/row_codec.h"

#include <algorithm>
#include <bit>
#include <cstdint>

#include "common/pose.h"
#include "common/sha256.h"

namespace semmap::sqlite {

Status BindPose(Statement& stmt, int first, const Eigen::Isometry3d& T) {
  if (!T.matrix().allFinite()) return InvalidArgumentError("pose has a non-finite value");
  const PoseTq p = ToPoseTq(T);
  const double values[7] = {p.t.x(), p.t.y(), p.t.z(), p.q.x(), p.q.y(), p.q.z(), p.q.w()};
  for (int i = 0; i < 7; ++i) SEMMAP_RETURN_IF_ERROR(stmt.BindDouble(first + i, values[i]));
  return OkStatus();
}

Eigen::Isometry3d ReadPose(const Statement& stmt, int first) {
  PoseTq p;
  p.t = Eigen::Vector3d(stmt.ColumnDouble(first), stmt.ColumnDouble(first + 1),
                        stmt.ColumnDouble(first + 2));
  // Eigen's constructor order is (w, x, y, z).
  p.q = Eigen::Quaterniond(stmt.ColumnDouble(first + 6), stmt.ColumnDouble(first + 3),
                           stmt.ColumnDouble(first + 4), stmt.ColumnDouble(first + 5));
  return ToIsometry(p);
}

std::string EncodeInformation(const InformationMatrix& information) {
  std::string bytes;
  bytes.reserve(36 * 8);
  for (int r = 0; r < 6; ++r) {
    for (int c = 0; c < 6; ++c) {
      const uint64_t bits = std::bit_cast<uint64_t>(information(r, c));
      for (int b = 0; b < 8; ++b) bytes.push_back(static_cast<char>((bits >> (8 * b)) & 0xff));
    }
  }
  return bytes;
}

StatusOr<InformationMatrix> DecodeInformation(std::string_view bytes) {
  if (bytes.size() != 36 * 8) {
    return DataLossError("information matrix has " + std::to_string(bytes.size()) +
                         " bytes, expected 288");
  }
  InformationMatrix information;
  for (int i = 0; i < 36; ++i) {
    uint64_t bits = 0;
    for (int b = 0; b < 8; ++b) {
      bits |= static_cast<uint64_t>(static_cast<unsigned char>(bytes[i * 8 + b])) << (8 * b);
    }
    information(i / 6, i % 6) = std::bit_cast<double>(bits);
  }
  return information;
}

std::string Sha256Bytes(std::string_view data) {
  const Sha256Digest digest = Sha256(data);
  return std::string(reinterpret_cast<const char*>(digest.data()), digest.size());
}

Status VerifyChecksummed(const std::string& name, const std::string& data, int64_t length,
                         const std::string& stored_digest) {
  if (static_cast<int64_t>(data.size()) != length) {
    return DataLossError(name + " is corrupt: stored length " + std::to_string(length) + ", read " +
                         std::to_string(data.size()) + " bytes");
  }
  const Sha256Digest digest = Sha256(data);
  if (stored_digest.size() != digest.size() ||
      !std::equal(digest.begin(), digest.end(), stored_digest.begin(),
                  [](uint8_t a, char b) { return a == static_cast<uint8_t>(b); })) {
    return DataLossError(name + " is corrupt: its sha256 " + ToHex(digest) +
                         " does not match the stored checksum");
  }
  return OkStatus();
}

}  // namespace semmap::sqlite
