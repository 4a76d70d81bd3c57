#pragma once
// Runs the real mrsns-sim binary from tests: to completion (exit code, stdout,
// stderr) or in the background until its ready file appears.
#include <chrono>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>
#include <thread>
#include <vector>

#include "background_process.h"
#include "cli_runner.h"

namespace mrsns::test {

inline std::filesystem::path simBinary() {
  const char* binary = std::getenv("MRSNS_BINARY_DIR");
  if (binary == nullptr) binary = MRSNS_TEST_BINARY_DIR;
  return std::filesystem::path(binary ? binary : ".") / "app" / "sim" / "mrsns-sim";
}

/// The bundled default scenario (the source tree's).
inline std::filesystem::path defaultScenario() {
  return std::filesystem::path(MRSNS_TEST_SOURCE_DIR) / ".." / "resources" / "scenarios" / "default.json";
}

/// `mrsns-sim ARGS...` to completion.
inline CliResult runSim(const std::vector<std::string>& args) {
  return runProgram(simBinary(), args);
}

/// `mrsns-sim ARGS...` in the background (e.g. `run ... --ready-file F`).
class SimProcess : public BackgroundProcess {
 public:
  explicit SimProcess(const std::vector<std::string>& args) : BackgroundProcess(argv(args)) {}

  /// The ready file's JSON once it appears (null after timeout_s, or when the process ended first).
  nlohmann::json waitReady(const std::filesystem::path& ready, double timeout_s = 30.0) {
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout_s);
    while (std::chrono::steady_clock::now() < deadline) {
      if (std::filesystem::exists(ready)) return nlohmann::json::parse(slurpFile(ready));
      if (ended()) return nullptr;
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
    return nullptr;
  }

 private:
  static std::vector<std::string> argv(const std::vector<std::string>& args) {
    std::vector<std::string> v = {simBinary().string()};
    v.insert(v.end(), args.begin(), args.end());
    return v;
  }
};

}  // namespace mrsns::test
