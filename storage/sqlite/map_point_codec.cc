#include "storage/sqlite/map_point_codec.h"

#include <cstdint>
#include <limits>

namespace semmap::sqlite {
namespace {

// Little-endian regardless of the host: the database file moves between machines.
void AppendLe(std::string& out, uint64_t value, int bytes) {
  for (int b = 0; b < bytes; ++b) out.push_back(static_cast<char>((value >> (8 * b)) & 0xff));
}

// The caller has checked that `bytes` bytes are there at `offset`.
uint64_t ReadLe(std::string_view in, size_t offset, int bytes) {
  uint64_t value = 0;
  for (int b = 0; b < bytes; ++b) {
    value |= static_cast<uint64_t>(static_cast<unsigned char>(in[offset + b])) << (8 * b);
  }
  return value;
}

}  // namespace

StatusOr<std::string> EncodeMapPointObservations(
    const std::vector<MapPointObservationRecord>& observations) {
  if (observations.size() > std::numeric_limits<uint32_t>::max()) {
    return InvalidArgumentError(std::to_string(observations.size()) +
                                " observations are more than a map point can store");
  }
  std::string bytes;
  bytes.reserve(kMapPointCountBytes + observations.size() * kMapPointObservationBytes);
  AppendLe(bytes, observations.size(), 4);
  for (size_t i = 0; i < observations.size(); ++i) {
    const MapPointObservationRecord& o = observations[i];
    if (o.keypoint < 0) {
      return InvalidArgumentError("observation " + std::to_string(i) + " has keypoint " +
                                  std::to_string(o.keypoint));
    }
    // Two's complement is the representation of int64_t (C++20): the casts are lossless.
    AppendLe(bytes, static_cast<uint64_t>(o.session_id), 8);
    AppendLe(bytes, static_cast<uint64_t>(o.seq), 8);
    AppendLe(bytes, static_cast<uint32_t>(o.keypoint), 4);
  }
  return bytes;
}

StatusOr<std::vector<MapPointObservationRecord>> DecodeMapPointObservations(
    std::string_view bytes) {
  if (bytes.size() < kMapPointCountBytes) {
    return DataLossError("map point observations have " + std::to_string(bytes.size()) +
                         " bytes, fewer than their count needs");
  }
  // The stored count must agree with the length; only the length sizes anything.
  const uint64_t stored_count = ReadLe(bytes, 0, 4);
  const size_t payload = bytes.size() - kMapPointCountBytes;
  const size_t count = payload / kMapPointObservationBytes;
  if (payload % kMapPointObservationBytes != 0 || stored_count != count) {
    return DataLossError("map point observations count " + std::to_string(stored_count) +
                         " but have " + std::to_string(bytes.size()) + " bytes");
  }
  std::vector<MapPointObservationRecord> observations(count);
  for (size_t i = 0; i < count; ++i) {
    const size_t at = kMapPointCountBytes + i * kMapPointObservationBytes;
    MapPointObservationRecord& o = observations[i];
    o.session_id = static_cast<int64_t>(ReadLe(bytes, at, 8));
    o.seq = static_cast<int64_t>(ReadLe(bytes, at + 8, 8));
    o.keypoint = static_cast<int32_t>(static_cast<uint32_t>(ReadLe(bytes, at + 16, 4)));
    if (o.keypoint < 0) {
      return DataLossError("map point observation " + std::to_string(i) + " has keypoint " +
                           std::to_string(o.keypoint));
    }
  }
  return observations;
}

}  // namespace semmap::sqlite
