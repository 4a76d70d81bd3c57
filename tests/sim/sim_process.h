#pragma once
// Runs the real mrsns-sim binary from tests: to completion (exit code, stdout,
// stderr) or in the background until its ready file appears.
#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>
#include <thread>
#include <vector>

#include "background_process.h"
#include "cli_runner.h"
#include "test_data.h"

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

/// The default room without its patient, robot, probe, phantoms or faults, and with only the tools named (in
/// the default's order; a test fails when one is missing): for a test of one device or task. Its tracker on a
/// port of the system's choice, running until stopped, its headset pointed at `hmd_port`.
inline nlohmann::json defaultRoomWith(const std::string& name, int seed, std::uint16_t hmd_port,
                                      const std::vector<std::string>& tools) {
  nlohmann::json s = nlohmann::json::parse(slurpFile(defaultScenario()));
  s["name"] = name;
  s["seed"] = seed;
  s["duration_s"] = 0.0;
  s["tracker"]["port"] = 0;
  for (const char* key : {"patient", "robot", "flat_target", "ultrasound", "nwire_phantom"}) s.erase(key);
  s["faults"] = nlohmann::json::array();
  nlohmann::json kept = nlohmann::json::array();
  for (const auto& tool : s["tools"]) {
    if (std::find(tools.begin(), tools.end(), tool["name"].get<std::string>()) != tools.end()) kept.push_back(tool);
  }
  EXPECT_EQ(kept.size(), tools.size()) << "the default scenario's tools " << nlohmann::json(tools).dump();
  s["tools"] = kept;
  s["hmd"]["port"] = hmd_port;
  return s;
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
