// Connection and Statement: pragmas at open, error statuses, binds/columns, statement cache.
#include "storage/sqlite/connection.h"

#include <gtest/gtest.h>

#include "tests/unit/storage/storage_test_util.h"

namespace semmap::sqlite {
namespace {

using storage_test::TempDir;

std::unique_ptr<Connection> OpenOrDie(const std::string& path, ConnectionOptions options = {}) {
  auto connection = Connection::Open(path, options);
  EXPECT_TRUE(connection.ok()) << connection.status().ToString();
  return connection.ok() ? std::move(connection).value() : nullptr;
}

std::string QueryText(Connection& db, std::string_view sql) {
  auto stmt = db.Prepare(sql);
  EXPECT_TRUE(stmt.ok()) << stmt.status().ToString();
  auto row = (*stmt)->Step();
  EXPECT_TRUE(row.ok() && *row) << sql;
  return (*stmt)->ColumnText(0);
}

TEST(ConnectionTest, OpenAppliesPragmas) {
  TempDir dir;
  ConnectionOptions options;
  options.busy_timeout_ms = 1234;
  auto db = OpenOrDie(dir.File("a.db"), options);
  ASSERT_NE(db, nullptr);
  EXPECT_EQ(QueryText(*db, "PRAGMA journal_mode"), "wal");
  EXPECT_EQ(*db->QueryInt64("PRAGMA foreign_keys"), 1);
  EXPECT_EQ(*db->QueryInt64("PRAGMA busy_timeout"), 1234);
  EXPECT_EQ(*db->QueryInt64("PRAGMA synchronous"), 2);  // FULL
  EXPECT_EQ(db->path(), dir.File("a.db"));
}

TEST(ConnectionTest, SynchronousNormalAndDefaultBusyTimeout) {
  TempDir dir;
  ConnectionOptions options;
  options.synchronous = Synchronous::kNormal;
  auto db = OpenOrDie(dir.File("a.db"), options);
  ASSERT_NE(db, nullptr);
  EXPECT_EQ(*db->QueryInt64("PRAGMA synchronous"), 1);  // NORMAL
  EXPECT_EQ(*db->QueryInt64("PRAGMA busy_timeout"), 5000);
}

TEST(ConnectionTest, OpenInMissingDirectoryFailsClearly) {
  TempDir dir;
  auto db = Connection::Open(dir.File("missing/sub/a.db"), {});
  ASSERT_FALSE(db.ok());
  EXPECT_EQ(db.status().code(), StatusCode::kFailedPrecondition);
  EXPECT_NE(db.status().message().find("missing/sub/a.db"), std::string::npos);
  EXPECT_NE(db.status().message().find("unable to open database file"), std::string::npos)
      << db.status().ToString();
}

TEST(ConnectionTest, OpenWithoutCreateFailsForMissingFile) {
  TempDir dir;
  ConnectionOptions options;
  options.create_if_missing = false;
  auto db = Connection::Open(dir.File("absent.db"), options);
  ASSERT_FALSE(db.ok());
  EXPECT_EQ(db.status().code(), StatusCode::kFailedPrecondition);
}

TEST(ConnectionTest, NotADatabaseIsDataLoss) {
  TempDir dir;
  {
    std::FILE* f = std::fopen(dir.File("junk.db").c_str(), "wb");
    ASSERT_NE(f, nullptr);
    const std::string junk(4096, 'x');
    std::fwrite(junk.data(), 1, junk.size(), f);
    std::fclose(f);
  }
  auto db = Connection::Open(dir.File("junk.db"), {});
  ASSERT_FALSE(db.ok());
  EXPECT_EQ(db.status().code(), StatusCode::kDataLoss) << db.status().ToString();
  EXPECT_NE(db.status().message().find("file is not a database"), std::string::npos);
}

TEST(ConnectionTest, ExecErrorNamesOperationAndSqliteMessage) {
  TempDir dir;
  auto db = OpenOrDie(dir.File("a.db"));
  ASSERT_NE(db, nullptr);
  Status status = db->Exec("SELEC nonsense");
  ASSERT_FALSE(status.ok());
  EXPECT_EQ(status.code(), StatusCode::kInternal);
  EXPECT_NE(status.message().find("exec `SELEC nonsense`"), std::string::npos) << status.message();
  EXPECT_NE(status.message().find("syntax error"), std::string::npos) << status.message();

  auto prepared = db->Prepare("SELECT * FROM no_such_table");
  ASSERT_FALSE(prepared.ok());
  EXPECT_NE(prepared.status().message().find("no such table: no_such_table"), std::string::npos);
  EXPECT_NE(prepared.status().message().find("prepare"), std::string::npos);
}

TEST(ConnectionTest, ConstraintViolationsMapToStatusCodes) {
  TempDir dir;
  auto db = OpenOrDie(dir.File("a.db"));
  ASSERT_NE(db, nullptr);
  ASSERT_OK(
      db->Exec("CREATE TABLE p (id INTEGER PRIMARY KEY, name TEXT UNIQUE, n INTEGER CHECK (n > 0));"
               "CREATE TABLE c (p_id INTEGER REFERENCES p(id));"
               "INSERT INTO p VALUES (1, 'a', 1);"));
  EXPECT_EQ(db->Exec("INSERT INTO p VALUES (2, 'a', 1)").code(), StatusCode::kAlreadyExists);
  EXPECT_EQ(db->Exec("INSERT INTO p VALUES (1, 'b', 1)").code(), StatusCode::kAlreadyExists);
  EXPECT_EQ(db->Exec("INSERT INTO p VALUES (3, 'c', 0)").code(), StatusCode::kInvalidArgument);
  // foreign_keys=ON is in effect.
  Status fk = db->Exec("INSERT INTO c VALUES (42)");
  EXPECT_EQ(fk.code(), StatusCode::kFailedPrecondition);
  EXPECT_NE(fk.message().find("FOREIGN KEY constraint failed"), std::string::npos);
}

TEST(ConnectionTest, BindStepAndColumns) {
  TempDir dir;
  auto db = OpenOrDie(dir.File("a.db"));
  ASSERT_NE(db, nullptr);
  ASSERT_OK(db->Exec("CREATE TABLE t (i INTEGER, d REAL, s TEXT, b BLOB, n ANY) STRICT"));
  const std::string bytes("\0\x01\xffz", 4);
  {
    auto insert = db->Prepare("INSERT INTO t VALUES (?1, ?2, ?3, ?4, ?5)");
    ASSERT_OK(insert.status());
    ASSERT_OK((*insert)->BindInt64(1, int64_t{1} << 40));
    ASSERT_OK((*insert)->BindDouble(2, 2.5));
    ASSERT_OK((*insert)->BindText(3, "héllo"));
    ASSERT_OK((*insert)->BindBlob(4, bytes));
    ASSERT_OK((*insert)->BindNull(5));
    ASSERT_OK((*insert)->Run());
    EXPECT_EQ(db->changes(), 1);
    EXPECT_EQ(db->last_insert_rowid(), 1);
  }
  {
    auto insert = db->Prepare("INSERT INTO t VALUES (?1, ?2, ?3, ?4, ?5)");
    ASSERT_OK(insert.status());
    ASSERT_OK((*insert)->BindAll(7, 0.25, std::string("x"), Blob{""}, nullptr));
    ASSERT_OK((*insert)->Run());
    EXPECT_EQ(db->last_insert_rowid(), 2);
  }
  auto select = db->Prepare("SELECT i, d, s, b, n FROM t ORDER BY rowid");
  ASSERT_OK(select.status());
  Statement& s = **select;
  EXPECT_EQ(s.ColumnCount(), 5);
  ASSERT_TRUE(*s.Step());
  EXPECT_EQ(s.ColumnInt64(0), int64_t{1} << 40);
  EXPECT_EQ(s.ColumnDouble(1), 2.5);
  EXPECT_EQ(s.ColumnText(2), "héllo");
  EXPECT_EQ(s.ColumnBlob(3), bytes);
  EXPECT_TRUE(s.ColumnIsNull(4));
  ASSERT_TRUE(*s.Step());
  EXPECT_EQ(s.ColumnInt64(0), 7);
  EXPECT_EQ(s.ColumnText(2), "x");
  EXPECT_FALSE(s.ColumnIsNull(3));  // an empty blob is not NULL
  EXPECT_EQ(s.ColumnBlob(3), "");
  EXPECT_FALSE(*s.Step());
}

TEST(ConnectionTest, BindOutOfRangeIsAnError) {
  TempDir dir;
  auto db = OpenOrDie(dir.File("a.db"));
  ASSERT_NE(db, nullptr);
  auto stmt = db->Prepare("SELECT ?1");
  ASSERT_OK(stmt.status());
  Status status = (*stmt)->BindInt64(2, 1);
  EXPECT_EQ(status.code(), StatusCode::kInvalidArgument);
  EXPECT_NE(status.message().find("bind parameter 2"), std::string::npos) << status.message();
}

TEST(ConnectionTest, PrepareRefusesSeveralStatements) {
  TempDir dir;
  auto db = OpenOrDie(dir.File("a.db"));
  ASSERT_NE(db, nullptr);
  EXPECT_EQ(db->Prepare("SELECT 1; SELECT 2").status().code(), StatusCode::kInvalidArgument);
  EXPECT_OK(db->Prepare("SELECT 1;").status());
}

TEST(ConnectionTest, StatementCacheReusesAndResets) {
  TempDir dir;
  auto db = OpenOrDie(dir.File("a.db"));
  ASSERT_NE(db, nullptr);
  ASSERT_OK(db->Exec("CREATE TABLE t (v INTEGER); INSERT INTO t VALUES (1), (2), (3);"));
  Statement* first = nullptr;
  {
    auto stmt = db->Prepare("SELECT v FROM t WHERE v >= ?1 ORDER BY v");
    ASSERT_OK(stmt.status());
    first = &**stmt;
    ASSERT_OK((*stmt)->BindInt64(1, 2));
    ASSERT_TRUE(*(*stmt)->Step());
    EXPECT_EQ((*stmt)->ColumnInt64(0), 2);
    // Left half-read and bound: the next lease must start clean.
  }
  auto again = db->Prepare("SELECT v FROM t WHERE v >= ?1 ORDER BY v");
  ASSERT_OK(again.status());
  EXPECT_EQ(&**again, first);  // the cached statement, not a new one
  // Rewound and unbound: ?1 is NULL now and "v >= NULL" matches no row.
  EXPECT_FALSE(*(*again)->Step());
  (*again)->Reset();
  ASSERT_OK((*again)->BindInt64(1, 3));
  ASSERT_TRUE(*(*again)->Step());
  EXPECT_EQ((*again)->ColumnInt64(0), 3);
}

TEST(ConnectionTest, ResetClearsBindings) {
  TempDir dir;
  auto db = OpenOrDie(dir.File("a.db"));
  ASSERT_NE(db, nullptr);
  {
    auto stmt = db->Prepare("SELECT ?1");
    ASSERT_OK(stmt.status());
    ASSERT_OK((*stmt)->BindInt64(1, 42));
    ASSERT_TRUE(*(*stmt)->Step());
    EXPECT_EQ((*stmt)->ColumnInt64(0), 42);
  }
  auto stmt = db->Prepare("SELECT ?1");
  ASSERT_OK(stmt.status());
  ASSERT_TRUE(*(*stmt)->Step());
  EXPECT_TRUE((*stmt)->ColumnIsNull(0));
}

TEST(ConnectionTest, NestedUseOfTheSameSqlGetsItsOwnStatement) {
  TempDir dir;
  auto db = OpenOrDie(dir.File("a.db"));
  ASSERT_NE(db, nullptr);
  ASSERT_OK(db->Exec("CREATE TABLE t (v INTEGER); INSERT INTO t VALUES (1), (2);"));
  auto outer = db->Prepare("SELECT v FROM t ORDER BY v");
  ASSERT_OK(outer.status());
  ASSERT_TRUE(*(*outer)->Step());
  {
    auto inner = db->Prepare("SELECT v FROM t ORDER BY v");
    ASSERT_OK(inner.status());
    EXPECT_NE(&**inner, &**outer);
    ASSERT_TRUE(*(*inner)->Step());
    EXPECT_EQ((*inner)->ColumnInt64(0), 1);
  }
  // The outer iteration was not disturbed.
  EXPECT_EQ((*outer)->ColumnInt64(0), 1);
  ASSERT_TRUE(*(*outer)->Step());
  EXPECT_EQ((*outer)->ColumnInt64(0), 2);
}

// An unfinished SELECT keeps a WAL read snapshot open; the lease must end it so the connection
// sees later commits from other connections.
TEST(ConnectionTest, ReleasedLeaseDoesNotPinAnOldSnapshot) {
  TempDir dir;
  auto writer = OpenOrDie(dir.File("a.db"));
  auto reader = OpenOrDie(dir.File("a.db"));
  ASSERT_NE(writer, nullptr);
  ASSERT_NE(reader, nullptr);
  ASSERT_OK(writer->Exec("CREATE TABLE t (v INTEGER); INSERT INTO t VALUES (1), (2);"));
  {
    auto stmt = reader->Prepare("SELECT v FROM t");
    ASSERT_OK(stmt.status());
    ASSERT_TRUE(*(*stmt)->Step());  // one row of two: the read is still open
  }
  ASSERT_OK(writer->Exec("INSERT INTO t VALUES (3)"));
  EXPECT_EQ(*reader->QueryInt64("SELECT COUNT(*) FROM t"), 3);
}

TEST(ConnectionTest, QueryInt64WithoutRowIsAnError) {
  TempDir dir;
  auto db = OpenOrDie(dir.File("a.db"));
  ASSERT_NE(db, nullptr);
  ASSERT_OK(db->Exec("CREATE TABLE t (v INTEGER)"));
  EXPECT_EQ(db->QueryInt64("SELECT v FROM t").status().code(), StatusCode::kInternal);
}

TEST(ConnectionTest, BusyWriterIsUnavailableAfterTimeout) {
  TempDir dir;
  ConnectionOptions quick;
  quick.busy_timeout_ms = 50;
  auto a = OpenOrDie(dir.File("a.db"), quick);
  auto b = OpenOrDie(dir.File("a.db"), quick);
  ASSERT_NE(a, nullptr);
  ASSERT_NE(b, nullptr);
  ASSERT_OK(a->Exec("CREATE TABLE t (v INTEGER)"));
  ASSERT_OK(a->Exec("BEGIN IMMEDIATE"));
  Status busy = b->Exec("BEGIN IMMEDIATE");
  EXPECT_EQ(busy.code(), StatusCode::kUnavailable) << busy.ToString();
  EXPECT_NE(busy.message().find("database is locked"), std::string::npos) << busy.message();
  ASSERT_OK(a->Exec("ROLLBACK"));
}

}  // namespace
}  // namespace semmap::sqlite
