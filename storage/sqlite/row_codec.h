// How domain values map onto columns: poses as translation + unit quaternion (7 REAL columns),
// 6x6 information matrices as 288-byte little-endian BLOBs, checksummed payloads as data +
// length + 32-byte SHA-256.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstdint>
#include <string>
#include <string_view>

#include "common/status.h"
#include "storage/sqlite/statement.h"

namespace semmap::sqlite {

using InformationMatrix = Eigen::Matrix<double, 6, 6>;

// Binds tx ty tz qx qy qz qw to parameters first..first+6. A non-finite pose is refused
// (SQLite would store NaN as NULL).
Status BindPose(Statement& stmt, int first, const Eigen::Isometry3d& T);
// Reads tx ty tz qx qy qz qw from columns first..first+6.
Eigen::Isometry3d ReadPose(const Statement& stmt, int first);

// 36 doubles, row-major, each little-endian regardless of the host.
std::string EncodeInformation(const InformationMatrix& information);
StatusOr<InformationMatrix> DecodeInformation(std::string_view bytes);

// The SHA-256 of `data` as the 32 raw bytes stored beside it.
std::string Sha256Bytes(std::string_view data);
// Length and SHA-256 stored beside a payload: a truncated or altered value (disk error, manual
// edit) is DATA_LOSS naming `name` instead of reaching a parser.
Status VerifyChecksummed(const std::string& name, const std::string& data, int64_t length,
                         const std::string& stored_digest);

}  // namespace semmap::sqlite
