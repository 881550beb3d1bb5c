#include "storage/sqlite/connection.h"

#include <sqlite3.h>

#include "storage/sqlite/sqlite_error.h"

namespace semmap::sqlite {

StatusOr<std::unique_ptr<Connection>> Connection::Open(const std::string& path,
                                                       const ConnectionOptions& options) {
  if (options.busy_timeout_ms < 0) return InvalidArgumentError("busy_timeout_ms must be >= 0");
  int flags = SQLITE_OPEN_NOMUTEX;  // a connection is never shared between threads at once
  if (options.read_only) {
    flags |= SQLITE_OPEN_READONLY;
  } else {
    flags |= SQLITE_OPEN_READWRITE;
    if (options.create_if_missing) flags |= SQLITE_OPEN_CREATE;
  }
  sqlite3* db = nullptr;
  const int rc = sqlite3_open_v2(path.c_str(), &db, flags, nullptr);
  // sqlite3_open_v2 hands back a handle even on failure; it must be closed either way.
  std::unique_ptr<Connection> connection(new Connection(db, path));
  if (rc != SQLITE_OK) {
    const Status error = SqliteError(rc, db, "open " + path);
    return Status(error.code(), error.message() + " (its directory must exist and be writable)");
  }
  sqlite3_extended_result_codes(db, 1);
  // READWRITE silently degrades to read-only when the OS refuses write access.
  if (!options.read_only && sqlite3_db_readonly(db, "main") == 1) {
    return FailedPreconditionError("database " + path +
                                   " is read-only (check file and directory permissions)");
  }
  SEMMAP_RETURN_IF_ERROR(connection->ApplyPragmas(options).WithContext("open " + path));
  return connection;
}

Connection::~Connection() {
  cache_.clear();  // finalize statements before closing
  // close_v2 defers the close if a statement is somehow still alive instead of failing.
  sqlite3_close_v2(db_);
}

Status Connection::ApplyPragmas(const ConnectionOptions& options) {
  // busy_timeout first: setting WAL mode may itself wait for another connection's lock.
  SEMMAP_RETURN_IF_ERROR(Exec("PRAGMA busy_timeout = " + std::to_string(options.busy_timeout_ms)));
  SEMMAP_RETURN_IF_ERROR(Exec("PRAGMA foreign_keys = ON"));
  SEMMAP_RETURN_IF_ERROR(Exec(options.synchronous == Synchronous::kFull
                                  ? "PRAGMA synchronous = FULL"
                                  : "PRAGMA synchronous = NORMAL"));
  if (options.read_only) return OkStatus();
  // The pragma answers with the mode in effect; anything but "wal" means WAL is unavailable
  // (e.g. a file system without shared memory) and readers would block the writer.
  SEMMAP_ASSIGN_OR_RETURN(
      std::unique_ptr<Statement> wal,
      Statement::Prepare(db_, "PRAGMA journal_mode = WAL", /*persistent=*/false));  // run once
  SEMMAP_ASSIGN_OR_RETURN(bool row, wal->Step());
  const std::string mode = row ? wal->ColumnText(0) : "";
  if (mode != "wal") {
    return FailedPreconditionError("cannot enable WAL journal mode (got '" + mode + "')");
  }
  return OkStatus();
}

Status Connection::Exec(const std::string& sql) {
  char* error = nullptr;
  const int rc = sqlite3_exec(db_, sql.c_str(), nullptr, nullptr, &error);
  sqlite3_free(error);  // sqlite3_errmsg still holds the same text
  if (rc != SQLITE_OK)
    return SqliteError(rc, db_, "exec `" + std::string(SqlForMessage(sql)) + "`");
  return OkStatus();
}

StatusOr<StatementLease> Connection::Prepare(std::string_view sql) {
  auto it = cache_.find(sql);
  if (it == cache_.end()) {
    SEMMAP_ASSIGN_OR_RETURN(std::unique_ptr<Statement> stmt,
                            Statement::Prepare(db_, sql, /*persistent=*/true));
    it = cache_.emplace(std::string(sql), std::move(stmt)).first;
  } else if (it->second->leased_) {
    SEMMAP_ASSIGN_OR_RETURN(std::unique_ptr<Statement> stmt,
                            Statement::Prepare(db_, sql, /*persistent=*/false));
    return StatementLease(std::move(stmt));
  }
  it->second->Reset();  // reset on reuse: whatever the last user left behind is gone
  return StatementLease(it->second.get());
}

StatusOr<int64_t> Connection::QueryInt64(std::string_view sql) {
  SEMMAP_ASSIGN_OR_RETURN(StatementLease stmt, Prepare(sql));
  SEMMAP_ASSIGN_OR_RETURN(bool row, stmt->Step());
  if (!row) return InternalError("query returned no row: " + std::string(SqlForMessage(sql)));
  return stmt->ColumnInt64(0);
}

int64_t Connection::last_insert_rowid() const { return sqlite3_last_insert_rowid(db_); }

int64_t Connection::changes() const { return sqlite3_changes64(db_); }

bool Connection::in_transaction() const { return sqlite3_get_autocommit(db_) == 0; }

}  // namespace semmap::sqlite
