// Transaction: commit keeps, anything else rolls back.
#include "storage/sqlite/transaction.h"

#include <gtest/gtest.h>

#include "tests/unit/storage/storage_test_util.h"

namespace semmap::sqlite {
namespace {

class TransactionTest : public ::testing::Test {
 protected:
  void SetUp() override {
    auto db = Connection::Open(dir_.File("t.db"), {});
    ASSERT_TRUE(db.ok()) << db.status().ToString();
    db_ = std::move(db).value();
    ASSERT_OK(db_->Exec("CREATE TABLE t (v INTEGER)"));
  }
  int64_t Rows() { return *db_->QueryInt64("SELECT COUNT(*) FROM t"); }

  storage_test::TempDir dir_;
  std::unique_ptr<Connection> db_;
};

TEST_F(TransactionTest, CommitKeepsTheWrites) {
  auto txn = Transaction::Begin(*db_);
  ASSERT_OK(txn.status());
  EXPECT_TRUE(db_->in_transaction());
  ASSERT_OK(db_->Exec("INSERT INTO t VALUES (1)"));
  ASSERT_OK(txn->Commit());
  EXPECT_FALSE(txn->active());
  EXPECT_FALSE(db_->in_transaction());
  EXPECT_EQ(Rows(), 1);
  EXPECT_EQ(txn->Commit().code(), StatusCode::kFailedPrecondition);  // only once
}

TEST_F(TransactionTest, DestructorRollsBackWhenNotCommitted) {
  {
    auto txn = Transaction::Begin(*db_);
    ASSERT_OK(txn.status());
    ASSERT_OK(db_->Exec("INSERT INTO t VALUES (1)"));
    EXPECT_EQ(Rows(), 1);  // visible inside the transaction
  }
  EXPECT_FALSE(db_->in_transaction());
  EXPECT_EQ(Rows(), 0);
}

TEST_F(TransactionTest, EarlyReturnRollsBack) {
  auto write_then_fail = [&]() -> Status {
    SEMMAP_ASSIGN_OR_RETURN(Transaction txn, Transaction::Begin(*db_));
    SEMMAP_RETURN_IF_ERROR(db_->Exec("INSERT INTO t VALUES (1)"));
    SEMMAP_RETURN_IF_ERROR(db_->Exec("INSERT INTO missing VALUES (1)"));
    return txn.Commit();
  };
  EXPECT_FALSE(write_then_fail().ok());
  EXPECT_FALSE(db_->in_transaction());
  EXPECT_EQ(Rows(), 0);
}

TEST_F(TransactionTest, ExplicitRollback) {
  auto txn = Transaction::Begin(*db_);
  ASSERT_OK(txn.status());
  ASSERT_OK(db_->Exec("INSERT INTO t VALUES (1)"));
  ASSERT_OK(txn->Rollback());
  EXPECT_OK(txn->Rollback());  // idempotent
  EXPECT_EQ(Rows(), 0);
}

TEST_F(TransactionTest, MovedTransactionRollsBackOnce) {
  {
    auto txn = Transaction::Begin(*db_);
    ASSERT_OK(txn.status());
    Transaction moved = std::move(txn).value();
    EXPECT_TRUE(moved.active());
    ASSERT_OK(db_->Exec("INSERT INTO t VALUES (1)"));
  }
  EXPECT_EQ(Rows(), 0);
  EXPECT_FALSE(db_->in_transaction());
}

TEST_F(TransactionTest, NestedBeginIsRefused) {
  auto txn = Transaction::Begin(*db_);
  ASSERT_OK(txn.status());
  auto nested = Transaction::Begin(*db_);
  EXPECT_EQ(nested.status().code(), StatusCode::kFailedPrecondition);
  EXPECT_TRUE(db_->in_transaction());  // the outer one is untouched
}

TEST_F(TransactionTest, BeginIsImmediate) {
  // A second connection cannot start writing while the first holds the transaction.
  ConnectionOptions quick;
  quick.busy_timeout_ms = 20;
  auto other = Connection::Open(dir_.File("t.db"), quick);
  ASSERT_OK(other.status());
  auto txn = Transaction::Begin(*db_);
  ASSERT_OK(txn.status());
  auto blocked = Transaction::Begin(**other);
  EXPECT_EQ(blocked.status().code(), StatusCode::kUnavailable) << blocked.status().ToString();
  ASSERT_OK(txn->Commit());
  auto now_free = Transaction::Begin(**other);
  EXPECT_OK(now_free.status());
}

}  // namespace
}  // namespace semmap::sqlite
