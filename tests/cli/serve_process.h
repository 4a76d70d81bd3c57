#pragma once
// Runs `mrsns-cli serve ...` in the background (the test talks to it over
// loopback meanwhile), then stops it with SIGTERM or waits for it.
#include <fcntl.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "cli_runner.h"
#include "mrsns/igtlink/server.h"

extern char** environ;

namespace mrsns::test {

/// A free loopback port (bound once by a throw-away server, then released).
inline std::uint16_t freePort() {
  igtlink::ServerOptions options;
  options.port = 0;
  igtlink::Server server(options);
  server.start();
  const auto port = server.port();
  server.stop();
  return port;
}

class ServeProcess {
 public:
  explicit ServeProcess(const std::vector<std::string>& args) {
    const auto dir = std::filesystem::temp_directory_path() / ("mrsns-serve-" + std::to_string(::getpid()));
    std::filesystem::create_directories(dir);
    out_ = dir / ("out" + std::to_string(counter_) + ".txt");
    err_ = dir / ("err" + std::to_string(counter_++) + ".txt");
    std::vector<std::string> argv_strings = {cliBinary().string(), "serve"};
    argv_strings.insert(argv_strings.end(), args.begin(), args.end());
    std::vector<char*> argv;
    for (auto& a : argv_strings) argv.push_back(a.data());
    argv.push_back(nullptr);
    posix_spawn_file_actions_t actions;
    posix_spawn_file_actions_init(&actions);
    posix_spawn_file_actions_addopen(&actions, 1, out_.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    posix_spawn_file_actions_addopen(&actions, 2, err_.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    posix_spawn_file_actions_addopen(&actions, 0, "/dev/null", O_RDONLY, 0);
    if (posix_spawn(&pid_, argv[0], &actions, nullptr, argv.data(), environ) != 0) pid_ = -1;
    posix_spawn_file_actions_destroy(&actions);
  }
  ~ServeProcess() {
    if (pid_ > 0 && !finished_) {
      ::kill(pid_, SIGKILL);
      int status = 0;
      ::waitpid(pid_, &status, 0);
    }
  }
  ServeProcess(const ServeProcess&) = delete;
  ServeProcess& operator=(const ServeProcess&) = delete;

  [[nodiscard]] bool started() const { return pid_ > 0; }
  void terminate() {
    if (pid_ > 0) ::kill(pid_, SIGTERM);
  }
  /// Waits up to timeout_s for the process to end; exit code, stdout, stderr.
  CliResult wait(double timeout_s = 10.0) {
    CliResult result;
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout_s);
    int status = 0;
    while (true) {
      const pid_t r = ::waitpid(pid_, &status, WNOHANG);
      if (r == pid_) break;
      if (std::chrono::steady_clock::now() > deadline) {
        ::kill(pid_, SIGKILL);
        ::waitpid(pid_, &status, 0);
        result.err = "(killed after timeout)";
        break;
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(5));
    }
    finished_ = true;
    result.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
    auto slurp = [](const std::filesystem::path& p) {
      std::ifstream in(p, std::ios::binary);
      std::stringstream ss;
      ss << in.rdbuf();
      return ss.str();
    };
    result.out = slurp(out_);
    result.err += slurp(err_);
    return result;
  }

 private:
  static inline int counter_ = 0;
  pid_t pid_ = -1;
  bool finished_ = false;
  std::filesystem::path out_;
  std::filesystem::path err_;
};

}  // namespace mrsns::test
