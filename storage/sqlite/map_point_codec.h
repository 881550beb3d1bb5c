// The observations of a stored map point (map_points.observations, schema v5) as one BLOB:
//
//   count     uint32, little-endian
//   count x   session_id int64, seq int64, keypoint int32 (each little-endian: 20 bytes)
//
// so a blob is exactly 4 + 20 * count bytes. Keypoints are never negative.
#pragma once

#include <cstddef>
#include <string>
#include <string_view>
#include <vector>

#include "common/map_types.h"
#include "common/status.h"

namespace semmap::sqlite {

inline constexpr size_t kMapPointCountBytes = 4;
inline constexpr size_t kMapPointObservationBytes = 20;

// INVALID_ARGUMENT for a negative keypoint or more observations than the count can hold
// (nothing the decoder would refuse is ever written).
StatusOr<std::string> EncodeMapPointObservations(
    const std::vector<MapPointObservationRecord>& observations);
// DATA_LOSS for anything EncodeMapPointObservations cannot have written: a blob shorter than
// the count, a length that is not 4 + 20 * count, a negative keypoint.
StatusOr<std::vector<MapPointObservationRecord>> DecodeMapPointObservations(std::string_view bytes);

}  // namespace semmap::sqlite
