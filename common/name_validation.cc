#include "common/name_validation.h"

namespace semmap {

Status ValidateName(const std::string& what, const std::string& name) {
  if (name.empty()) return InvalidArgumentError(what + " name is empty");
  if (name.size() > 128) return InvalidArgumentError(what + " name is longer than 128 bytes");
  for (unsigned char c : name) {
    if (c < 0x20 || c == 0x7f || c == '/') {
      std::string message = what;
      message += " name '";
      message += name;
      message += "' contains a control character or '/'";
      return InvalidArgumentError(std::move(message));
    }
  }
  if (name.front() == ' ' || name.back() == ' ') {
    return InvalidArgumentError(what + " name '" + name + "' has leading or trailing spaces");
  }
  return OkStatus();
}

}  // namespace semmap
