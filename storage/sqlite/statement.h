// RAII prepared statement (sqlite3_stmt) with typed binds, stepping and column reads, plus the
// lease through which a connection lends out its cached statements.
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>
#include <string>
#include <string_view>
#include <type_traits>

#include "common/status.h"

struct sqlite3;
struct sqlite3_stmt;

namespace semmap::sqlite {

// Marks a BindAll argument as a BLOB (plain strings bind as TEXT). The bytes are copied.
struct Blob {
  std::string_view bytes;
};

class Statement {
 public:
  // `persistent` hints SQLite that the statement is cached and reused many times.
  static StatusOr<std::unique_ptr<Statement>> Prepare(sqlite3* db, std::string_view sql,
                                                      bool persistent);
  ~Statement();  // finalizes
  Statement(const Statement&) = delete;
  Statement& operator=(const Statement&) = delete;

  // Parameters are numbered from 1, as in SQLite. Text and Blob copy their bytes.
  Status BindInt64(int index, int64_t value);
  Status BindDouble(int index, double value);
  Status BindText(int index, std::string_view value);
  Status BindBlob(int index, std::string_view bytes);
  // No copy, for large payloads: `bytes` must stay alive until the statement is reset.
  Status BindBlobNoCopy(int index, std::string_view bytes);
  Status BindNull(int index);
  // Binds args to parameters 1..N: integers and bools as INTEGER, floating point as REAL,
  // strings as TEXT, Blob as BLOB, nullptr as NULL. Stops at the first failure.
  template <typename... Args>
  Status BindAll(const Args&... args);

  // Advances: true when a row is ready, false when the statement is done.
  StatusOr<bool> Step();
  // Steps to completion, for statements that return no rows (INSERT/UPDATE/DELETE).
  Status Run();
  // Rewinds and clears every binding so a cached statement starts clean; also ends the
  // read transaction an unfinished SELECT would otherwise keep open.
  void Reset();

  int ColumnCount() const;
  bool ColumnIsNull(int column) const;
  int64_t ColumnInt64(int column) const;
  double ColumnDouble(int column) const;
  std::string ColumnText(int column) const;
  std::string ColumnBlob(int column) const;

  const std::string& sql() const { return sql_; }

 private:
  friend class Connection;  // checks leased_ before lending a cached statement
  friend class StatementLease;
  Statement(sqlite3* db, sqlite3_stmt* stmt, std::string sql)
      : db_(db), stmt_(stmt), sql_(std::move(sql)) {}
  Status BindResult(int rc, int index);
  template <typename T>
  Status BindValue(int index, const T& value);

  sqlite3* db_;
  sqlite3_stmt* stmt_;
  std::string sql_;
  bool leased_ = false;  // a cached statement currently lent out by its connection
};

// A statement lent by Connection::Prepare. Acts like a Statement*, and resets the statement when
// it goes out of scope so the next user starts clean and no read stays open by accident.
// Must not outlive the connection that lent it.
class StatementLease {
 public:
  explicit StatementLease(Statement* cached);                 // borrowed from the cache
  explicit StatementLease(std::unique_ptr<Statement> owned);  // one-off (cached one was busy)
  ~StatementLease();
  StatementLease(StatementLease&& other) noexcept;
  StatementLease& operator=(StatementLease&&) = delete;
  StatementLease(const StatementLease&) = delete;
  StatementLease& operator=(const StatementLease&) = delete;

  Statement* operator->() const { return stmt_; }
  Statement& operator*() const { return *stmt_; }

 private:
  Statement* stmt_;
  std::unique_ptr<Statement> owned_;
};

template <typename T>
Status Statement::BindValue(int index, const T& value) {
  if constexpr (std::is_same_v<T, std::nullptr_t>) {
    return BindNull(index);
  } else if constexpr (std::is_same_v<T, Blob>) {
    return BindBlob(index, value.bytes);
  } else if constexpr (std::is_integral_v<T>) {
    return BindInt64(index, static_cast<int64_t>(value));
  } else if constexpr (std::is_floating_point_v<T>) {
    return BindDouble(index, static_cast<double>(value));
  } else {
    return BindText(index, std::string_view(value));
  }
}

template <typename... Args>
Status Statement::BindAll(const Args&... args) {
  Status status;
  int index = 1;
  // && short-circuits: binding stops at the first failure.
  (void)((status = BindValue(index++, args), status.ok()) && ...);
  return status;
}

}  // namespace semmap::sqlite
