// A write transaction that cannot be left open by accident: BEGIN IMMEDIATE on creation,
// ROLLBACK in the destructor unless Commit() succeeded.
#pragma once

#include "common/status.h"
#include "storage/sqlite/connection.h"

namespace semmap::sqlite {

class Transaction {
 public:
  // IMMEDIATE takes the write lock now, so a busy database fails here (after busy_timeout)
  // rather than half-way through the writes with a lock upgrade that cannot be retried.
  static StatusOr<Transaction> Begin(Connection& connection);
  ~Transaction();
  Transaction(Transaction&& other) noexcept;
  Transaction& operator=(Transaction&&) = delete;
  Transaction(const Transaction&) = delete;
  Transaction& operator=(const Transaction&) = delete;

  // After a failed commit the transaction is still open and the destructor rolls it back.
  Status Commit();
  // Rolls back now; later calls (and the destructor) do nothing.
  Status Rollback();
  bool active() const { return connection_ != nullptr; }

 private:
  explicit Transaction(Connection* connection) : connection_(connection) {}

  Connection* connection_;  // null once committed, rolled back or moved from
};

}  // namespace semmap::sqlite
