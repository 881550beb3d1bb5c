// Schema versioning through PRAGMA user_version: numbered steps, each applied once, all pending
// steps in one transaction so a crash never leaves a half-migrated database.
#pragma once

#include <span>

#include "common/status.h"
#include "storage/sqlite/connection.h"

namespace semmap::sqlite {

struct Migration {
  int version;              // 1, 2, 3, ... without gaps
  const char* description;  // for error messages
  const char* sql;          // one or more statements
};

// The steps this binary knows; the last one's version is the schema version it writes.
std::span<const Migration> SchemaMigrations();
int LatestSchemaVersion();

StatusOr<int> ReadSchemaVersion(Connection& connection);

// Applies the steps newer than the database's user_version and sets user_version to the last
// one. A database already at that version is left untouched (no write lock is taken); one that
// is newer is refused with FAILED_PRECONDITION, since an old binary could corrupt it.
Status ApplyMigrations(Connection& connection, std::span<const Migration> migrations);

}  // namespace semmap::sqlite
