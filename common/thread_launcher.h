// Starting a thread can fail: at the process's or the system's thread limit std::thread throws
// std::system_error, which nothing in a server thread should let escape (std::terminate). Code
// that starts threads on behalf of a client goes through a ThreadLauncher, so that failure is a
// Status (RESOURCE_EXHAUSTED) the client is told, and tests can make it fail.
#pragma once

#include <functional>
#include <thread>

#include "common/status.h"

namespace semmap {

using ThreadLauncher = std::function<StatusOr<std::thread>(std::function<void()> body)>;

// Starts `body` on a new thread; RESOURCE_EXHAUSTED (with the system's reason) when it cannot.
StatusOr<std::thread> LaunchThread(std::function<void()> body);

}  // namespace semmap
