// Serving on unix:/PATH: what to check before gRPC binds there.
#pragma once

#include <string>

#include "common/status.h"

namespace semmap {

// OK when `path` is free to bind: absent, or a socket nothing listens on any more (a server
// that stopped without removing it; gRPC replaces it). UNAVAILABLE when a server answers there
// (gRPC would silently take the path from it); FAILED_PRECONDITION when something other than a
// socket is there (never replaced).
Status CheckUnixSocketPathFree(const std::string& path);

}  // namespace semmap
