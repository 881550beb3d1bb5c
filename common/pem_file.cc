#include "common/pem_file.h"

#include <fstream>
#include <sstream>

namespace semmap {

StatusOr<std::string> ReadPemFile(const std::string& path, std::string_view flag) {
  constexpr std::streamoff kMaxBytes = 1 << 20;
  const std::string named = std::string(flag) + " " + path;
  std::ifstream in(path, std::ios::binary);
  if (!in) return InvalidArgumentError(named + ": cannot be read");
  in.seekg(0, std::ios::end);
  const std::streamoff size = in.tellg();
  if (size <= 0) return InvalidArgumentError(named + ": empty or not a regular file");
  if (size > kMaxBytes) return InvalidArgumentError(named + ": larger than 1 MiB, not a PEM file");
  in.seekg(0, std::ios::beg);
  std::ostringstream text;
  text << in.rdbuf();
  if (!in && !in.eof()) return InvalidArgumentError(named + ": read failed");
  std::string pem = text.str();
  if (pem.find("-----BEGIN ") == std::string::npos) {
    return InvalidArgumentError(named + ": no PEM block (-----BEGIN ...) in it");
  }
  return pem;
}

}  // namespace semmap
