// RAII SQLite connection: opened with the pragmas semmap relies on (WAL, foreign keys, busy
// timeout, synchronous level) and a cache of prepared statements keyed by their SQL text.
// Not thread-safe: one thread uses a connection at a time (the server gives each its own).
#pragma once

#include <cstdint>
#include <map>
#include <memory>
#include <string>
#include <string_view>

#include "common/status.h"
#include "storage/sqlite/statement.h"

struct sqlite3;

namespace semmap::sqlite {

enum class Synchronous {
  kFull,    // every commit reaches the disk before it returns (survives power loss)
  kNormal,  // WAL: commits survive a process crash, the last ones may be lost on power loss
};

struct ConnectionOptions {
  bool read_only = false;
  bool create_if_missing = true;  // ignored when read_only
  int busy_timeout_ms = 5000;     // how long to wait for another connection's lock
  Synchronous synchronous = Synchronous::kFull;
};

class Connection {
 public:
  // Opens `path` and applies journal_mode=WAL (unless read-only), foreign_keys=ON, busy_timeout
  // and synchronous. Fails (never aborts) when the file cannot be opened for writing.
  static StatusOr<std::unique_ptr<Connection>> Open(const std::string& path,
                                                    const ConnectionOptions& options);
  ~Connection();
  Connection(const Connection&) = delete;
  Connection& operator=(const Connection&) = delete;

  // Runs one or more statements that return nothing of interest (DDL, PRAGMA, BEGIN...).
  Status Exec(const std::string& sql);
  // The cached statement for `sql` (prepared on first use), reset and without bindings.
  // When the cached one is still lent out (a nested use of the same SQL), a one-off statement is
  // prepared instead, so leases never disturb each other.
  StatusOr<StatementLease> Prepare(std::string_view sql);
  // Runs a query that yields one row with one integer column (COUNT, PRAGMA user_version, ...).
  StatusOr<int64_t> QueryInt64(std::string_view sql);

  int64_t last_insert_rowid() const;
  int64_t changes() const;  // rows changed by the last INSERT/UPDATE/DELETE
  bool in_transaction() const;
  const std::string& path() const { return path_; }
  sqlite3* raw() const { return db_; }  // for tests and one-off tools

 private:
  Connection(sqlite3* db, std::string path) : db_(db), path_(std::move(path)) {}
  Status ApplyPragmas(const ConnectionOptions& options);

  sqlite3* db_;
  std::string path_;
  // std::less<> lets a string_view look up a std::string key without a copy.
  std::map<std::string, std::unique_ptr<Statement>, std::less<>> cache_;
};

}  // namespace semmap::sqlite
