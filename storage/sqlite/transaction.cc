#include "storage/sqlite/transaction.h"

namespace semmap::sqlite {

StatusOr<Transaction> Transaction::Begin(Connection& connection) {
  if (connection.in_transaction()) {
    return FailedPreconditionError("a transaction is already open on " + connection.path());
  }
  SEMMAP_RETURN_IF_ERROR(connection.Exec("BEGIN IMMEDIATE"));
  return Transaction(&connection);
}

Transaction::Transaction(Transaction&& other) noexcept : connection_(other.connection_) {
  other.connection_ = nullptr;
}

Transaction::~Transaction() {
  // A destructor cannot report; the rollback of an abandoned transaction only fails when SQLite
  // already rolled it back itself, which is the outcome we want anyway.
  Status ignored = Rollback();
  (void)ignored;
}

Status Transaction::Commit() {
  if (connection_ == nullptr) return FailedPreconditionError("transaction is not active");
  Status status = connection_->Exec("COMMIT");
  if (status.ok() || !connection_->in_transaction()) connection_ = nullptr;
  return status;
}

Status Transaction::Rollback() {
  if (connection_ == nullptr) return OkStatus();
  Connection* connection = connection_;
  connection_ = nullptr;
  // Some errors (SQLITE_FULL, SQLITE_IOERR, ...) roll the transaction back automatically;
  // a second ROLLBACK would only fail with "no transaction is active".
  if (!connection->in_transaction()) return OkStatus();
  return connection->Exec("ROLLBACK");
}

}  // namespace semmap::sqlite
