#pragma once

#include <string>

#include "common/status.h"

namespace semmap {

// Map and session names: 1..128 printable characters, no leading/trailing space, no '/'.
Status ValidateName(const std::string& what, const std::string& name);

}  // namespace semmap
