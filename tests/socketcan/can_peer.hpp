// can-utils (cansend, candump) as child processes of a SocketCAN test, their stdout and
// stderr on one pipe. Every wait is poll() with a deadline.
#pragma once

#include <fcntl.h>
#include <poll.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <cstdlib>
#include <cstring>
#include <optional>
#include <string>
#include <utility>
#include <vector>

extern char** environ;

namespace polyport::test {

using Clock = std::chrono::steady_clock;

inline int ms_until(Clock::time_point deadline) {
  const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(deadline - Clock::now()).count();
  return left > 0 ? static_cast<int>(left) : 0;
}

class CanPeer {
 public:
  // Starts `args` (args[0] looked up in PATH); empty error() when it runs.
  explicit CanPeer(std::vector<std::string> args) {
    int fds[2];
    if (::pipe2(fds, O_CLOEXEC) != 0) {
      error_ = std::string("pipe2: ") + std::strerror(errno);
      return;
    }
    output_fd_ = fds[0];
    posix_spawn_file_actions_t actions;
    posix_spawn_file_actions_init(&actions);
    posix_spawn_file_actions_addopen(&actions, 0, "/dev/null", O_RDONLY, 0);
    posix_spawn_file_actions_adddup2(&actions, fds[1], 1);
    posix_spawn_file_actions_adddup2(&actions, fds[1], 2);
    std::vector<char*> argv;
    for (auto& arg : args) argv.push_back(arg.data());
    argv.push_back(nullptr);
    const int rc = ::posix_spawnp(&pid_, args[0].c_str(), &actions, nullptr, argv.data(), environ);
    posix_spawn_file_actions_destroy(&actions);
    ::close(fds[1]);
    if (rc != 0) {
      pid_ = -1;
      error_ = "cannot start " + args[0] + " (package can-utils): " + std::strerror(rc);
    }
  }
  CanPeer(const CanPeer&) = delete;
  CanPeer& operator=(const CanPeer&) = delete;
  ~CanPeer() {
    if (pid_ > 0) {
      ::kill(pid_, SIGKILL);
      ::waitpid(pid_, nullptr, 0);
    }
    if (output_fd_ >= 0) ::close(output_fd_);
  }

  const std::string& error() const { return error_; }
  const std::string& output() const { return output_; }

  // Whether the peer has written something (or closed its output) within `timeout_ms`.
  bool output_ready(int timeout_ms) const {
    pollfd p{output_fd_, POLLIN, 0};
    return ::poll(&p, 1, timeout_ms) > 0;
  }

  // Reads its output to the end and reaps it: its exit status, nullopt at the deadline.
  std::optional<int> finish(Clock::time_point deadline) {
    char buffer[1024];
    while (output_fd_ >= 0) {
      pollfd p{output_fd_, POLLIN, 0};
      if (::poll(&p, 1, ms_until(deadline)) <= 0) return std::nullopt;
      const ssize_t n = ::read(output_fd_, buffer, sizeof buffer);
      if (n > 0) {
        output_.append(buffer, static_cast<std::size_t>(n));
      } else if (n == 0 || errno != EINTR) {
        ::close(output_fd_);
        output_fd_ = -1;
      }
    }
    int status = 0;
    while (::waitpid(pid_, &status, WNOHANG) == 0) {
      if (Clock::now() > deadline) return std::nullopt;
      ::poll(nullptr, 0, 1);
    }
    pid_ = -1;
    return WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
  }

 private:
  pid_t pid_ = -1;
  int output_fd_ = -1;
  std::string output_;
  std::string error_;
};

// Runs a command to its end: empty on success, else what went wrong.
inline std::string run_command(std::vector<std::string> args) {
  std::string line;
  for (const auto& arg : args) line += (line.empty() ? "" : " ") + arg;
  CanPeer peer(std::move(args));
  if (!peer.error().empty()) return peer.error();
  const auto status = peer.finish(Clock::now() + std::chrono::seconds(5));
  if (!status) return line + " did not finish within 5 s";
  if (*status != 0) return line + " failed: " + peer.output();
  return {};
}

// Runs `cansend interface frame` to its end: empty on success, else what went wrong.
inline std::string cansend(const std::string& interface, const std::string& frame) {
  return run_command({"cansend", interface, frame});
}

}  // namespace polyport::test
