#include "tests/testing/test_store.h"

namespace semmap::testing {

StatusOr<std::unique_ptr<TestStore>> MakeTestStore(const std::string& map_name,
                                                   const std::string& session_name,
                                                   const CameraCalibration& camera,
                                                   double depth_scale) {
  auto store = std::make_unique<TestStore>();
  store->db_path = store->dir.File("semmap.db");
  SEMMAP_ASSIGN_OR_RETURN(std::unique_ptr<SqliteMapStore> write,
                          SqliteMapStore::Open(store->db_path, {}));
  SEMMAP_ASSIGN_OR_RETURN(store->read, SqliteMapStore::Open(store->db_path, {}));
  SEMMAP_ASSIGN_OR_RETURN(store->map, write->GetOrCreateMap(map_name));
  SessionInfo session;
  session.map_id = store->map.id;
  session.name = session_name;
  session.mode = SessionMode::kRgbd;
  session.camera = camera;
  session.depth_scale = depth_scale;
  SEMMAP_ASSIGN_OR_RETURN(store->session, write->CreateSession(session));
  SEMMAP_ASSIGN_OR_RETURN(store->writer, StorageWriter::Start(std::move(write), {}));
  return store;
}

}  // namespace semmap::testing
