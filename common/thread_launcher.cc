#include "common/thread_launcher.h"

#include <string>
#include <system_error>

namespace semmap {

StatusOr<std::thread> LaunchThread(std::function<void()> body) {
  try {
    return std::thread(std::move(body));
  } catch (const std::system_error& e) {
    return ResourceExhaustedError(std::string("cannot start a thread (") + e.what() +
                                  "): the server is at its thread limit");
  }
}

}  // namespace semmap
