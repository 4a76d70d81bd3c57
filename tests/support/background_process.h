#pragma once
// Runs a program in the background from a test (a server the test talks to
// over loopback), with stdout and stderr in files, then ends it with SIGTERM
// or waits for it. Killed with SIGKILL if the test leaves it running.
#include <fcntl.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <string>
#include <thread>
#include <vector>

#include "cli_runner.h"

extern char** environ;

namespace mrsns::test {

class BackgroundProcess {
 public:
  /// argv[0] is the program's path. Output goes to files in a per-process temporary folder.
  explicit BackgroundProcess(std::vector<std::string> argv) {
    const auto dir = std::filesystem::temp_directory_path() / ("mrsns-bg-" + std::to_string(::getpid()));
    std::filesystem::create_directories(dir);
    const int n = counter_++;
    out_ = dir / ("out" + std::to_string(n) + ".txt");
    err_ = dir / ("err" + std::to_string(n) + ".txt");
    std::vector<char*> args;
    for (auto& a : argv) args.push_back(a.data());
    args.push_back(nullptr);
    posix_spawn_file_actions_t actions;
    posix_spawn_file_actions_init(&actions);
    posix_spawn_file_actions_addopen(&actions, 1, out_.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    posix_spawn_file_actions_addopen(&actions, 2, err_.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    posix_spawn_file_actions_addopen(&actions, 0, "/dev/null", O_RDONLY, 0);
    if (posix_spawn(&pid_, args[0], &actions, nullptr, args.data(), environ) != 0) pid_ = -1;
    posix_spawn_file_actions_destroy(&actions);
  }
  ~BackgroundProcess() {
    if (pid_ > 0 && !finished_) {
      ::kill(pid_, SIGKILL);
      int status = 0;
      ::waitpid(pid_, &status, 0);
    }
  }
  BackgroundProcess(const BackgroundProcess&) = delete;
  BackgroundProcess& operator=(const BackgroundProcess&) = delete;

  [[nodiscard]] bool started() const { return pid_ > 0; }
  void terminate() {
    if (pid_ > 0 && !finished_) ::kill(pid_, SIGTERM);
  }
  /// True (and the exit code kept) once the process has ended; never blocks.
  bool ended() {
    if (finished_ || pid_ <= 0) return true;
    int status = 0;
    if (::waitpid(pid_, &status, WNOHANG) != pid_) return false;
    finished_ = true;
    exit_code_ = WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
    return true;
  }
  /// Waits up to timeout_s for the process to end (then kills it); exit code, stdout, stderr.
  CliResult wait(double timeout_s = 10.0) {
    CliResult result;
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout_s);
    while (!ended()) {
      if (std::chrono::steady_clock::now() > deadline) {
        ::kill(pid_, SIGKILL);
        int status = 0;
        ::waitpid(pid_, &status, 0);
        finished_ = true;
        exit_code_ = -1;
        result.err = "(killed after timeout)";
        break;
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(5));
    }
    result.exit_code = exit_code_;
    result.out = slurpFile(out_);
    result.err += slurpFile(err_);
    return result;
  }

 private:
  static inline int counter_ = 0;
  pid_t pid_ = -1;
  bool finished_ = false;
  int exit_code_ = -1;
  std::filesystem::path out_;
  std::filesystem::path err_;
};

}  // namespace mrsns::test
