// A real SQLite store in a temporary directory for tests of pipeline stages: one map with one
// RGBD session, the storage writer over its own connection (as the server runs it) and a
// second connection for reading back what the stage wrote.
#pragma once

#include <memory>
#include <string>

#include "common/camera.h"
#include "common/map_types.h"
#include "common/status.h"
#include "storage/sqlite/sqlite_map_store.h"
#include "storage/storage_writer.h"
#include "tests/testing/temp_dir.h"

namespace semmap::testing {

struct TestStore {
  TempDir dir;
  std::string db_path;
  MapInfo map;
  SessionInfo session;
  std::unique_ptr<SqliteMapStore> read;
  std::unique_ptr<StorageWriter> writer;
};

StatusOr<std::unique_ptr<TestStore>> MakeTestStore(const std::string& map_name,
                                                   const std::string& session_name,
                                                   const CameraCalibration& camera,
                                                   double depth_scale);

}  // namespace semmap::testing
