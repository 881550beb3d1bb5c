#include "server/unix_socket_path.h"

#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/un.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>

namespace semmap {
namespace {

// Closes the descriptor it holds.
class SocketFd {
 public:
  explicit SocketFd(int fd) : fd_(fd) {}
  SocketFd(const SocketFd&) = delete;
  SocketFd& operator=(const SocketFd&) = delete;
  ~SocketFd() {
    if (fd_ >= 0) ::close(fd_);
  }
  int get() const { return fd_; }

 private:
  int fd_;
};

}  // namespace

Status CheckUnixSocketPathFree(const std::string& path) {
  struct stat st {};
  if (::lstat(path.c_str(), &st) != 0) {
    if (errno == ENOENT) return OkStatus();
    return FailedPreconditionError("cannot look at unix socket path " + path + ": " +
                                   std::strerror(errno));
  }
  if (!S_ISSOCK(st.st_mode)) {
    return FailedPreconditionError("unix socket path " + path +
                                   " exists and is not a socket; not replacing it");
  }
  sockaddr_un address{};
  address.sun_family = AF_UNIX;
  if (path.size() >= sizeof(address.sun_path)) {
    return InvalidArgumentError("unix socket path " + path + " is too long");
  }
  std::memcpy(address.sun_path, path.c_str(), path.size() + 1);
  const SocketFd probe(::socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0));
  if (probe.get() < 0) {
    return UnavailableError(std::string("cannot make a socket: ") + std::strerror(errno));
  }
  if (::connect(probe.get(), reinterpret_cast<const sockaddr*>(&address), sizeof(address)) == 0) {
    return UnavailableError("a server is already listening on unix:" + path);
  }
  return OkStatus();  // ECONNREFUSED: a stale socket file
}

}  // namespace semmap
