#pragma once
// mrsns-sim as a child process of the trial: the simulated operating room the
// trial's live steps acquire from, run with a truth file the trial never
// reads (only `mrsns-sim score` does, in a second child process).
#include <filesystem>
#include <cstdint>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <sys/types.h>

namespace mrsns::workflow::detail {

/// The mrsns-sim program: $MRSNS_SIM, else beside the running program
/// (installed: /usr/bin), else the build tree's app/sim. Empty when none.
std::filesystem::path findSimProgram();

class SimulatedRoomProcess {
 public:
  /// Starts `mrsns-sim run` on `scenario` with every port chosen by the
  /// system (a scenario's headset, a client, is told a free local port for the
  /// workstation's hologram stream: endpoints()["hmd_port"], so rooms run side
  /// by side never meet each other's headsets); its truth goes to `truth`, its
  /// output to `log`; `seed` replaces the scenario's (mrsns-sim run --seed). Waits for the
  /// ready file. Throws FileError when the program cannot start or the room
  /// is not ready within `ready_timeout_s` (the message holds its log's tail).
  SimulatedRoomProcess(const std::filesystem::path& program, const std::filesystem::path& scenario,
                       const std::filesystem::path& truth, const std::filesystem::path& log,
                       double ready_timeout_s = 120.0, std::optional<std::uint64_t> seed = std::nullopt);
  ~SimulatedRoomProcess();
  SimulatedRoomProcess(const SimulatedRoomProcess&) = delete;
  SimulatedRoomProcess& operator=(const SimulatedRoomProcess&) = delete;

  [[nodiscard]] const std::string& host() const { return host_; }
  [[nodiscard]] int plusPort() const { return plus_port_; }
  /// The ready file's contents (ports of every device).
  [[nodiscard]] const nlohmann::json& endpoints() const { return endpoints_; }

  /// SIGTERM, then waits (the room writes its truth); returns the exit code (-1: killed after 30 s).
  int stop();

 private:
  pid_t pid_ = -1;
  std::string host_;
  int plus_port_ = 0;
  nlohmann::json endpoints_;
  std::filesystem::path log_;
};

/// `mrsns-sim score SESSION TRUTH --json`: its one JSON object. Throws
/// ComputationError with the scorer's error line when it fails.
nlohmann::json scoreWithSim(const std::filesystem::path& program, const std::filesystem::path& session,
                            const std::filesystem::path& truth, const std::filesystem::path& log);

}  // namespace mrsns::workflow::detail
