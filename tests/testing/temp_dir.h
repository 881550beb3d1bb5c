// A unique temporary directory removed (recursively) when the object dies.
#pragma once

#include <string>

namespace semmap::testing {

class TempDir {
 public:
  TempDir();
  ~TempDir();
  TempDir(const TempDir&) = delete;
  TempDir& operator=(const TempDir&) = delete;
  const std::string& path() const { return path_; }
  std::string File(const std::string& name) const { return path_ + "/" + name; }

 private:
  std::string path_;
};

// Where ../shared/data is (compile-time default, $SEMMAP_SHARED_DATA_DIR overrides);
// empty when it does not exist.
std::string SharedDataDir();

}  // namespace semmap::testing
