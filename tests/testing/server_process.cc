#include "tests/testing/server_process.h"

#include <poll.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <csignal>
#include <cstring>

namespace semmap::testing {
namespace {

std::vector<char*> Argv(const std::vector<std::string>& args) {
  std::vector<char*> out;
  out.reserve(args.size());
  for (const std::string& a : args) out.push_back(const_cast<char*>(a.c_str()));
  out.push_back(nullptr);
  return out;
}

// Starts argv with its stdout on a pipe; returns the child's pid (-1 on failure).
pid_t SpawnWithStdoutPipe(const std::vector<std::string>& args, int* stdout_fd) {
  int out[2];
  if (::pipe(out) != 0) return -1;
  const pid_t pid = ::fork();
  if (pid < 0) {
    ::close(out[0]);
    ::close(out[1]);
    return -1;
  }
  if (pid == 0) {
    ::dup2(out[1], STDOUT_FILENO);
    ::close(out[0]);
    ::close(out[1]);
    auto argv = Argv(args);
    ::execv(argv[0], argv.data());
    std::_Exit(127);
  }
  ::close(out[1]);
  *stdout_fd = out[0];
  return pid;
}

int WaitExit(pid_t pid) {
  int status = 0;
  while (::waitpid(pid, &status, 0) < 0 && errno == EINTR) {
  }
  if (WIFEXITED(status)) return WEXITSTATUS(status);
  if (WIFSIGNALED(status)) return 128 + WTERMSIG(status);
  return -1;
}

}  // namespace

std::string SemmapdPath() { return std::string(SEMMAP_BINARY_DIR) + "/server/semmapd"; }
std::string SemmapCliPath() { return std::string(SEMMAP_BINARY_DIR) + "/client/cli/semmap"; }

ServerProcess::~ServerProcess() {
  if (pid_ > 0) Stop(SIGKILL);
}

Status ServerProcess::Start(const std::string& data_dir,
                            const std::vector<std::string>& extra_flags) {
  std::vector<std::string> args = {SemmapdPath(), "--listen", "127.0.0.1:0", "--data-dir",
                                   data_dir};
  args.insert(args.end(), extra_flags.begin(), extra_flags.end());
  pid_ = SpawnWithStdoutPipe(args, &stdout_fd_);
  if (pid_ < 0) return InternalError("could not start " + args[0]);
  // Read until "semmapd: listening on HOST:PORT\n" (or 30 s, or the child dies).
  std::string text;
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(30);
  while (std::chrono::steady_clock::now() < deadline) {
    pollfd p{stdout_fd_, POLLIN, 0};
    if (::poll(&p, 1, 200) > 0) {
      char buf[256];
      const ssize_t n = ::read(stdout_fd_, buf, sizeof(buf));
      if (n <= 0) break;
      text.append(buf, static_cast<size_t>(n));
      const size_t at = text.find("listening on ");
      const size_t eol = at == std::string::npos ? at : text.find('\n', at);
      if (eol != std::string::npos) {
        address_ = text.substr(at + 13, eol - at - 13);
        return OkStatus();
      }
    }
  }
  Stop(SIGKILL);
  return UnavailableError("semmapd did not start; output: " + text);
}

int ServerProcess::Stop(int signal) {
  if (pid_ <= 0) return -1;
  ::kill(pid_, signal);
  const int code = WaitExit(pid_);
  pid_ = -1;
  if (stdout_fd_ >= 0) ::close(stdout_fd_);
  stdout_fd_ = -1;
  return code;
}

int RunCommand(const std::vector<std::string>& args, std::string* stdout_text) {
  int out = -1;
  const pid_t pid = SpawnWithStdoutPipe(args, &out);
  if (pid < 0) return -1;
  char buf[4096];
  ssize_t n;
  while ((n = ::read(out, buf, sizeof(buf))) > 0) {
    if (stdout_text) stdout_text->append(buf, static_cast<size_t>(n));
  }
  ::close(out);
  return WaitExit(pid);
}

}  // namespace semmap::testing
