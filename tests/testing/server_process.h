// Runs semmapd as a child process for end-to-end tests: waits for its "listening on" line,
// and stops it with a signal (SIGTERM for a clean stop, SIGKILL to simulate a crash).
#pragma once

#include <sys/types.h>

#include <string>
#include <vector>

#include "common/status.h"

namespace semmap::testing {

std::string SemmapdPath();    // the built semmapd binary
std::string SemmapCliPath();  // the built semmap binary

class ServerProcess {
 public:
  ServerProcess() = default;
  ~ServerProcess();  // SIGKILL if still running
  ServerProcess(const ServerProcess&) = delete;
  ServerProcess& operator=(const ServerProcess&) = delete;

  // Starts semmapd on 127.0.0.1:0 with the data dir and extra flags; fills address().
  Status Start(const std::string& data_dir, const std::vector<std::string>& extra_flags = {});
  // Sends `signal` and waits; returns the exit code (or 128+signal when killed by it).
  int Stop(int signal);
  const std::string& address() const { return address_; }
  pid_t pid() const { return pid_; }

 private:
  pid_t pid_ = -1;
  int stdout_fd_ = -1;
  std::string address_;
};

// Runs a command, capturing stdout; returns the exit code.
int RunCommand(const std::vector<std::string>& argv, std::string* stdout_text);

}  // namespace semmap::testing
