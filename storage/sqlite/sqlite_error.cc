#include "storage/sqlite/sqlite_error.h"

#include <sqlite3.h>

#include <string>

namespace semmap::sqlite {
namespace {

StatusCode CodeFor(int rc) {
  switch (rc) {
    case SQLITE_CONSTRAINT_UNIQUE:
    case SQLITE_CONSTRAINT_PRIMARYKEY:
      return StatusCode::kAlreadyExists;
    case SQLITE_CONSTRAINT_FOREIGNKEY:
      return StatusCode::kFailedPrecondition;
    default:
      break;
  }
  switch (rc & 0xff) {  // primary result code
    case SQLITE_CONSTRAINT:
    case SQLITE_MISMATCH:
    case SQLITE_RANGE:
    case SQLITE_TOOBIG:
      return StatusCode::kInvalidArgument;
    case SQLITE_BUSY:
    case SQLITE_LOCKED:
      return StatusCode::kUnavailable;  // another connection holds the lock: retryable
    case SQLITE_NOMEM:
    case SQLITE_FULL:
      return StatusCode::kResourceExhausted;
    case SQLITE_CORRUPT:
    case SQLITE_NOTADB:
      return StatusCode::kDataLoss;
    case SQLITE_CANTOPEN:
    case SQLITE_READONLY:
    case SQLITE_PERM:
    case SQLITE_AUTH:
      return StatusCode::kFailedPrecondition;
    case SQLITE_ABORT:
    case SQLITE_INTERRUPT:
      return StatusCode::kAborted;
    default:
      return StatusCode::kInternal;  // SQLITE_ERROR (bad SQL), SQLITE_IOERR, SQLITE_MISUSE, ...
  }
}

}  // namespace

Status SqliteError(int rc, sqlite3* db, std::string_view operation) {
  // sqlite3_errmsg describes the most recent failure on `db`, which is the one we are reporting
  // as long as nothing else ran on the connection in between (callers report immediately).
  const char* text = db != nullptr ? sqlite3_errmsg(db) : sqlite3_errstr(rc);
  std::string message = "sqlite " + std::string(operation) + ": " + text;
  if (db != nullptr && (rc & 0xff) != rc) {
    message += " (code " + std::to_string(rc) + ")";
  }
  return Status(CodeFor(rc), std::move(message));
}

std::string_view SqlForMessage(std::string_view sql) {
  constexpr size_t kMax = 80;
  const size_t start = sql.find_first_not_of(" \n\t");
  if (start == std::string_view::npos) return {};
  sql.remove_prefix(start);
  sql = sql.substr(0, sql.find('\n'));
  return sql.substr(0, kMax);
}

}  // namespace semmap::sqlite
