#pragma once
// Runs the real mrsns-cli binary from tests: exit code, stdout and stderr.
#include <gtest/gtest.h>
#include <sys/wait.h>

#include <atomic>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

namespace mrsns::test {

struct CliResult {
  int exit_code = -1;
  std::string out;
  std::string err;
};

inline std::filesystem::path cliBinary() {
  const char* binary = std::getenv("MRSNS_BINARY_DIR");
  if (binary == nullptr) binary = MRSNS_TEST_BINARY_DIR;
  return std::filesystem::path(binary ? binary : ".") / "app" / "cli" / "mrsns-cli";
}

inline std::string quoteArgument(const std::string& s) {
  std::string quoted = "'";
  for (char c : s) {
    if (c == '\'')
      quoted += "'\\''";
    else
      quoted += c;
  }
  return quoted + "'";
}

/// The whole content of a file ("" when it cannot be read).
inline std::string slurpFile(const std::filesystem::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

/// Runs `PROGRAM ARGS...` (arguments are shell-quoted) to its end and captures its output.
inline CliResult runProgram(const std::filesystem::path& program, const std::vector<std::string>& args) {
  // Tests run programs from several threads at once (rooms side by side): each call its own files.
  static std::atomic<int> counter{0};
  const int n = counter.fetch_add(1);
  const auto dir = std::filesystem::temp_directory_path() / ("mrsns-cli-test-" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  const auto out_file = dir / ("out" + std::to_string(n) + ".txt");
  const auto err_file = dir / ("err" + std::to_string(n) + ".txt");
  std::string command = quoteArgument(program.string());
  for (const auto& a : args) {
    // Appended in two steps: GCC 12 -O3 warns falsely (-Wrestrict) on `" " + std::string`.
    command += ' ';
    command += quoteArgument(a);
  }
  command += " >" + quoteArgument(out_file.string()) + " 2>" + quoteArgument(err_file.string()) + " </dev/null";
  const int status = std::system(command.c_str());
  CliResult result;
  result.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
  result.out = slurpFile(out_file);
  result.err = slurpFile(err_file);
  std::filesystem::remove(out_file);
  std::filesystem::remove(err_file);
  return result;
}

/// Runs `mrsns-cli ARGS...` and captures its output.
inline CliResult runCli(const std::vector<std::string>& args) {
  return runProgram(cliBinary(), args);
}

}  // namespace mrsns::test
