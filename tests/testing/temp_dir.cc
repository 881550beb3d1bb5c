#include "tests/testing/temp_dir.h"

#include <cstdlib>
#include <filesystem>
#include <system_error>

namespace semmap::testing {

TempDir::TempDir() {
  std::string tmpl = (std::filesystem::temp_directory_path() / "semmap-test-XXXXXX").string();
  if (::mkdtemp(tmpl.data()) == nullptr) std::abort();  // tests only: no temp dir, no test
  path_ = tmpl;
}

TempDir::~TempDir() {
  std::error_code ec;
  std::filesystem::remove_all(path_, ec);
}

std::string SharedDataDir() {
  std::string dir;
  if (const char* env = std::getenv("SEMMAP_SHARED_DATA_DIR"); env != nullptr && *env) {
    dir = env;
  } else {
#ifdef SEMMAP_SHARED_DATA_DIR
    dir = SEMMAP_SHARED_DATA_DIR;
#endif
  }
  std::error_code ec;
  return !dir.empty() && std::filesystem::is_directory(dir, ec) ? dir : std::string();
}

}  // namespace semmap::testing
