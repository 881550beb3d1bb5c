#include "storage/sqlite/statement.h"

#include <sqlite3.h>

#include <climits>
#include <string>

#include "storage/sqlite/sqlite_error.h"

namespace semmap::sqlite {

StatusOr<std::unique_ptr<Statement>> Statement::Prepare(sqlite3* db, std::string_view sql,
                                                        bool persistent) {
  if (sql.size() > static_cast<size_t>(INT_MAX)) return InvalidArgumentError("SQL too long");
  sqlite3_stmt* stmt = nullptr;
  const char* tail = nullptr;
  const int rc = sqlite3_prepare_v3(db, sql.data(), static_cast<int>(sql.size()),
                                    persistent ? SQLITE_PREPARE_PERSISTENT : 0, &stmt, &tail);
  if (rc != SQLITE_OK) {
    sqlite3_finalize(stmt);  // null-safe
    return SqliteError(rc, db, "prepare `" + std::string(SqlForMessage(sql)) + "`");
  }
  if (stmt == nullptr) return InvalidArgumentError("SQL has no statement: " + std::string(sql));
  // A second statement in the text would be silently ignored: refuse it instead.
  const std::string_view rest(tail, sql.data() + sql.size() - tail);
  if (rest.find_first_not_of(" \t\r\n;") != std::string_view::npos) {
    sqlite3_finalize(stmt);
    return InvalidArgumentError("SQL holds more than one statement: " + std::string(sql));
  }
  return std::unique_ptr<Statement>(new Statement(db, stmt, std::string(sql)));
}

Statement::~Statement() { sqlite3_finalize(stmt_); }

Status Statement::BindResult(int rc, int index) {
  if (rc == SQLITE_OK) return OkStatus();
  return SqliteError(
      rc, db_,
      "bind parameter " + std::to_string(index) + " of `" + std::string(SqlForMessage(sql_)) + "`");
}

Status Statement::BindInt64(int index, int64_t value) {
  return BindResult(sqlite3_bind_int64(stmt_, index, value), index);
}

Status Statement::BindDouble(int index, double value) {
  return BindResult(sqlite3_bind_double(stmt_, index, value), index);
}

Status Statement::BindText(int index, std::string_view value) {
  return BindResult(
      sqlite3_bind_text64(stmt_, index, value.data(), value.size(), SQLITE_TRANSIENT, SQLITE_UTF8),
      index);
}

Status Statement::BindBlob(int index, std::string_view bytes) {
  // A null pointer would bind NULL instead of an empty blob.
  const char* data = bytes.empty() ? "" : bytes.data();
  return BindResult(sqlite3_bind_blob64(stmt_, index, data, bytes.size(), SQLITE_TRANSIENT), index);
}

Status Statement::BindBlobNoCopy(int index, std::string_view bytes) {
  const char* data = bytes.empty() ? "" : bytes.data();
  return BindResult(sqlite3_bind_blob64(stmt_, index, data, bytes.size(), SQLITE_STATIC), index);
}

Status Statement::BindNull(int index) { return BindResult(sqlite3_bind_null(stmt_, index), index); }

StatusOr<bool> Statement::Step() {
  const int rc = sqlite3_step(stmt_);
  if (rc == SQLITE_ROW) return true;
  if (rc == SQLITE_DONE) return false;
  return SqliteError(rc, db_, "step `" + std::string(SqlForMessage(sql_)) + "`");
}

Status Statement::Run() {
  for (;;) {
    SEMMAP_ASSIGN_OR_RETURN(bool row, Step());
    if (!row) return OkStatus();
  }
}

void Statement::Reset() {
  // sqlite3_reset repeats the last step's error code; that error was already reported.
  sqlite3_reset(stmt_);
  sqlite3_clear_bindings(stmt_);
}

int Statement::ColumnCount() const { return sqlite3_column_count(stmt_); }

bool Statement::ColumnIsNull(int column) const {
  return sqlite3_column_type(stmt_, column) == SQLITE_NULL;
}

int64_t Statement::ColumnInt64(int column) const { return sqlite3_column_int64(stmt_, column); }

double Statement::ColumnDouble(int column) const { return sqlite3_column_double(stmt_, column); }

std::string Statement::ColumnText(int column) const {
  // Pointer first, then size: the documented order that avoids a conversion in between.
  const unsigned char* text = sqlite3_column_text(stmt_, column);
  const int size = sqlite3_column_bytes(stmt_, column);
  if (text == nullptr) return {};
  return std::string(reinterpret_cast<const char*>(text), static_cast<size_t>(size));
}

std::string Statement::ColumnBlob(int column) const {
  const void* data = sqlite3_column_blob(stmt_, column);
  const int size = sqlite3_column_bytes(stmt_, column);
  if (data == nullptr) return {};  // NULL or a zero-length blob
  return std::string(static_cast<const char*>(data), static_cast<size_t>(size));
}

StatementLease::StatementLease(Statement* cached) : stmt_(cached) { stmt_->leased_ = true; }

StatementLease::StatementLease(std::unique_ptr<Statement> owned)
    : stmt_(owned.get()), owned_(std::move(owned)) {}

StatementLease::StatementLease(StatementLease&& other) noexcept
    : stmt_(other.stmt_), owned_(std::move(other.owned_)) {
  other.stmt_ = nullptr;
}

StatementLease::~StatementLease() {
  if (stmt_ == nullptr) return;  // moved from
  stmt_->Reset();
  stmt_->leased_ = false;
}

}  // namespace semmap::sqlite
