#pragma once
// The in-project UR controller simulator: a SimulatedArm stepped in real time behind the network interfaces of a
// UR controller, so tests, trials and `mrsns-cli robot-sim` drive the same client code as a real robot.
//  - RTDE (30004): protocol v2 negotiation, controller version, output recipes (any documented output, at
//    1..500 Hz, sent every round(500 / f) control cycles), input recipes (input registers, IN_USE across
//    clients), start/pause, input data packages.
//  - Dashboard (29999): power on/off, brake release, play/stop/pause, robotmode, safetymode/safetystatus,
//    unlock protective stop, close safety popup, running, PolyscopeVersion, quit, and the PolyScope 5.6+ queries
//    client libraries make (is in remote control: true, get robot model: UR5, get serial number, programState,
//    get loaded program).
//  - Secondary (30002) and real-time (30003) script interfaces: one URScript command per line (servoj, speedl,
//    movel, movej, stopj, stopl, protective_stop); the secondary port also streams primary ROBOT_STATE messages
//    (robot mode, joint, cartesian and kinematics sub-packages) at 10 Hz after a VERSION message.
// Binds 127.0.0.1 unless told otherwise; port 0 picks a free port (tests). One I/O thread, one stepping thread.
#include <cstdint>
#include <memory>
#include <string>

#include "mrsns/robot/dashboard_protocol.h"
#include "mrsns/robot/rtde_protocol.h"
#include "mrsns/robot/simulated_arm.h"

namespace mrsns::robot {

struct UrSimulatorOptions {
  std::string host = "127.0.0.1";
  std::uint16_t rtde_port = rtde::kDefaultPort;
  std::uint16_t dashboard_port = dashboard::kDefaultPort;
  std::uint16_t secondary_port = 30002;
  std::uint16_t realtime_port = 30003;
  SimulatedArmOptions arm;
  /// Start powered with brakes released and the program running (a robot ready to be commanded). false: start
  /// in POWER_OFF like a controller after boot.
  bool start_ready = true;
  /// The controller refuses "unlock protective stop" earlier than this after the stop (UR: 5 s).
  double unlock_delay_s = 5.0;
  /// Controller software version: RTDE get_urcontrol_version, the primary VERSION message and the dashboard's
  /// PolyscopeVersion ("URSoftware 5.8.0.0 (...)"; clients such as ur_rtde need all four numbers).
  rtde::UrControlVersion version{5, 8, 0, 0};
  /// The dashboard's "get serial number" reply (digits only, as a real controller's).
  std::string serial_number = "20185500001";
};

struct UrSimulatorStats {
  std::uint64_t cycles = 0;
  std::uint64_t rtde_packages_sent = 0;
  std::uint64_t rtde_inputs_received = 0;
  std::uint64_t script_commands = 0;
  std::uint64_t script_rejected = 0;  // malformed lines, or motion refused by the robot's state
  std::uint64_t dashboard_commands = 0;
  std::uint64_t clients_connected = 0;
  std::uint64_t protocol_errors = 0;
};

class UrSimulator {
 public:
  /// Binds all four ports and starts. Throws NetworkError when an address cannot be bound (port in use),
  /// InvalidArgumentError for a host that is not an IP address.
  explicit UrSimulator(const UrSimulatorOptions& options = {});
  ~UrSimulator();
  UrSimulator(const UrSimulator&) = delete;
  UrSimulator& operator=(const UrSimulator&) = delete;

  /// Stops stepping, closes every connection and the listening sockets. Idempotent.
  void stop();

  [[nodiscard]] std::uint16_t rtdePort() const;
  [[nodiscard]] std::uint16_t dashboardPort() const;
  [[nodiscard]] std::uint16_t secondaryPort() const;
  [[nodiscard]] std::uint16_t realtimePort() const;
  [[nodiscard]] std::string host() const;

  /// The simulated arm (thread-safe): tests inject faults with arm().injectFault(kind, cycle).
  SimulatedArm& arm();
  [[nodiscard]] ArmState armState() const;
  [[nodiscard]] UrRobotMode robotMode() const;
  [[nodiscard]] UrSafetyMode safetyMode() const;
  [[nodiscard]] UrSimulatorStats stats() const;

  /// Closes every client connection (a cable pulled at the controller); the ports keep listening.
  void dropClients();
  /// While frozen the controller sends nothing and ignores commands, but keeps the connections open (a hung
  /// controller or a switch dropping packets): clients must notice from the silence.
  void setFrozen(bool frozen);

 private:
  struct Impl;
  std::shared_ptr<Impl> impl_;
};

}  // namespace mrsns::robot
