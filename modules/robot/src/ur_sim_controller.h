#pragma once
// The UR simulator's controller logic without sockets: power, brakes and program state on top of a SimulatedArm,
// the dashboard's replies, URScript execution, the RTDE session state machine and its output values. The network
// side (ur_simulator.cpp) only moves bytes. Thread-safe: one mutex for the controller state (the arm has its own).
#include <map>
#include <mutex>
#include <string>
#include <string_view>
#include <vector>

#include "mrsns/robot/ur_simulator.h"

namespace mrsns::robot::detail {

struct SimSnapshot {
  ArmState arm;
  UrRobotMode mode = UrRobotMode::PowerOff;
  UrSafetyMode safety = UrSafetyMode::Normal;
  bool program_running = false;
  bool link_up = true;  // false while the arm's link fault or the simulator's freeze holds
};

class SimController {
 public:
  explicit SimController(const UrSimulatorOptions& options);

  SimulatedArm& arm() { return arm_; }
  const UrSimulatorOptions& options() const { return options_; }
  /// One control period (skipped while frozen).
  void step();
  void setFrozen(bool frozen);
  [[nodiscard]] SimSnapshot snapshot() const;

  /// The reply line (without newline) to one dashboard line; `close` is set for "quit".
  std::string dashboard(std::string_view line, bool& close);
  /// Executes one script line; false (with `error`) when malformed or refused.
  bool script(std::string_view line, std::string& error);

  /// RTDE inputs: claims the variables for a session; per name its type, "NOT_FOUND" or "IN_USE".
  std::vector<std::string> claimInputs(const std::vector<std::string>& names, int session);
  void releaseInputs(int session);
  void setInput(const std::string& name, const rtde::Value& value);
  [[nodiscard]] rtde::Value inputValue(const std::string& name, rtde::FieldType type) const;

 private:
  [[nodiscard]] bool readyToMove() const;  // caller holds mutex_

  UrSimulatorOptions options_;
  SimulatedArm arm_;
  mutable std::mutex mutex_;
  bool powered_ = false;
  bool brakes_released_ = false;
  bool program_running_ = false;
  bool frozen_ = false;
  bool was_protective_ = false;
  double protective_since_s_ = 0;
  std::map<std::string, int> input_owner_;
  std::map<std::string, rtde::Value> inputs_;
};

/// One RTDE client's negotiation state.
class RtdeSession {
 public:
  RtdeSession(SimController& controller, int id) : controller_(controller), id_(id) {}
  ~RtdeSession() { controller_.releaseInputs(id_); }
  /// The reply bytes to a client package (empty when none is due).
  std::vector<std::uint8_t> handle(const rtde::Package& package);
  /// Whether a data package is due at this controller cycle.
  [[nodiscard]] bool dataDue(std::uint64_t cycle) const;
  [[nodiscard]] std::vector<std::uint8_t> dataPackage(const SimSnapshot& snapshot) const;

 private:
  SimController& controller_;
  int id_;
  std::uint16_t protocol_ = 0;
  rtde::Recipe outputs_;
  rtde::Recipe inputs_;
  std::uint64_t divider_ = 1;
  bool started_ = false;
  std::uint8_t next_recipe_id_ = 1;
};

/// The value of an RTDE output variable for a snapshot (documented units: m, rad, UR mode numbers).
rtde::Value outputValue(const rtde::Field& field, const SimSnapshot& s, const SimController& controller);
/// Whether `name` is an RTDE input the controller accepts in SETUP_INPUTS.
bool isRtdeInput(std::string_view name);

}  // namespace mrsns::robot::detail
