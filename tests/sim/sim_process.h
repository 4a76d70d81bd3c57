#pragma once
// Runs the real mrsns-sim binary from tests: to completion (exit code, stdout,
// stderr) or in the background until its ready file appears.
#include <fcntl.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "cli_runner.h"

extern char** environ;

namespace mrsns::test {

inline std::filesystem::path simBinary() {
  const char* binary = std::getenv("MRSNS_BINARY_DIR");
  if (binary == nullptr) binary = MRSNS_TEST_BINARY_DIR;
  return std::filesystem::path(binary ? binary : ".") / "app" / "sim" / "mrsns-sim";
}

inline std::string slurp(const std::filesystem::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

/// `mrsns-sim ARGS...` to completion.
inline CliResult runSim(const std::vector<std::string>& args) {
  static int counter = 0;
  const auto dir = std::filesystem::temp_directory_path() / ("mrsns-sim-test-" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  const auto out_file = dir / ("out" + std::to_string(counter) + ".txt");
  const auto err_file = dir / ("err" + std::to_string(counter++) + ".txt");
  std::string command = quoteArgument(simBinary().string());
  for (const auto& a : args) {
    command += ' ';
    command += quoteArgument(a);
  }
  command += " >" + quoteArgument(out_file.string()) + " 2>" + quoteArgument(err_file.string()) + " </dev/null";
  const int status = std::system(command.c_str());
  CliResult result;
  result.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
  result.out = slurp(out_file);
  result.err = slurp(err_file);
  return result;
}

/// `mrsns-sim run ...` in the background.
class SimProcess {
 public:
  SimProcess(const std::vector<std::string>& args, const std::filesystem::path& dir) : dir_(dir) {
    out_ = dir / "sim.out";
    err_ = dir / "sim.err";
    std::vector<std::string> argv_strings = {simBinary().string()};
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
  ~SimProcess() {
    if (pid_ > 0 && !finished_) {
      ::kill(pid_, SIGKILL);
      int status = 0;
      ::waitpid(pid_, &status, 0);
    }
  }
  SimProcess(const SimProcess&) = delete;
  SimProcess& operator=(const SimProcess&) = delete;

  /// The ready file's JSON once it appears (null after timeout_s, or when the process ended).
  nlohmann::json waitReady(const std::filesystem::path& ready, double timeout_s = 30.0) {
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout_s);
    while (std::chrono::steady_clock::now() < deadline) {
      if (std::filesystem::exists(ready)) return nlohmann::json::parse(slurp(ready));
      int status = 0;
      if (::waitpid(pid_, &status, WNOHANG) == pid_) {
        finished_ = true;
        exit_code_ = WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
        return nullptr;
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
    return nullptr;
  }
  void terminate() {
    if (pid_ > 0 && !finished_) ::kill(pid_, SIGTERM);
  }
  /// Waits for the end; exit code, stdout, stderr.
  CliResult wait(double timeout_s = 30.0) {
    CliResult r;
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout_s);
    while (!finished_) {
      int status = 0;
      if (::waitpid(pid_, &status, WNOHANG) == pid_) {
        finished_ = true;
        exit_code_ = WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
        break;
      }
      if (std::chrono::steady_clock::now() > deadline) {
        ::kill(pid_, SIGKILL);
        ::waitpid(pid_, &status, 0);
        finished_ = true;
        exit_code_ = -1;
        break;
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
    r.exit_code = exit_code_;
    r.out = slurp(out_);
    r.err = slurp(err_);
    return r;
  }
  [[nodiscard]] bool started() const { return pid_ > 0; }

 private:
  std::filesystem::path dir_, out_, err_;
  pid_t pid_ = -1;
  bool finished_ = false;
  int exit_code_ = -1;
};

}  // namespace mrsns::test
