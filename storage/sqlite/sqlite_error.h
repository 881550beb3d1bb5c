// Turns SQLite result codes into semmap::Status so no SQLite error escapes as a bare int.
#pragma once

#include <string_view>

#include "common/status.h"

struct sqlite3;

namespace semmap::sqlite {

// Status for a failed SQLite call: the code is chosen from the (extended) result code so callers
// can react (ALREADY_EXISTS for a UNIQUE violation, UNAVAILABLE for a busy database, DATA_LOSS
// for a corrupt file); the message names the operation and carries SQLite's own text.
// `db` may be null (then only the generic text of `rc` is available).
Status SqliteError(int rc, sqlite3* db, std::string_view operation);

// Shortens SQL for error messages (first line, at most ~80 characters).
std::string_view SqlForMessage(std::string_view sql);

}  // namespace semmap::sqlite
