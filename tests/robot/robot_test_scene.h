#pragma once
// A small deterministic scene for the supervisor, guidance and control-loop tests: the simulated UR5, a
// tracker seeing a marker on its flange and a patient reference, a plan in front of the drill, and
// switches that inject tracking faults.
#include <memory>

#include "mrsns/core/mesh.h"
#include "mrsns/core/rigid.h"
#include "mrsns/robot/control_loop.h"
#include "mrsns/robot/simulated_arm.h"

namespace mrsns::robot::test {

inline TriangleMesh boxMesh(const Eigen::Vector3d& center, double half) {
  TriangleMesh m;
  m.vertices.resize(8, 3);
  for (int i = 0; i < 8; ++i) {
    m.vertices.row(i) = (center + half * Eigen::Vector3d(i & 1 ? 1 : -1, i & 2 ? 1 : -1, i & 4 ? 1 : -1)).transpose();
  }
  m.faces.resize(12, 3);
  m.faces << 0, 2, 1, 1, 2, 3, 4, 5, 6, 5, 7, 6, 0, 1, 4, 1, 5, 4, 2, 6, 3, 3, 6, 7, 0, 4, 2, 2, 4, 6, 1, 3, 5, 3, 7, 5;
  return m;
}

struct Scene {
  std::shared_ptr<SimulatedArm> arm = std::make_shared<SimulatedArm>();
  Ur5Kinematics kin;
  ControlLoopSetup setup;
  ControlLoopOptions options;
  std::unique_ptr<ControlLoop> loop;
  Eigen::Isometry3d base_T_tracker = Eigen::Isometry3d::Identity();
  Eigen::Isometry3d flange_T_marker = Eigen::Isometry3d::Identity();
  Eigen::Isometry3d base_T_patient = Eigen::Isometry3d::Identity();  // the plan frame is the patient frame
  // Injected tracking faults.
  bool drill_visible = true, patient_visible = true, tracker_connected = true;
  double drill_delay_s = 0, patient_delay_s = 0;
  double cycle_time_s = 0;
  std::uint64_t missed = 0;

  Scene() {
    base_T_tracker.linear() = so3Exp(Eigen::Vector3d(0.2, -0.1, 2.5));
    base_T_tracker.translation() << -200, 1400, 500;
    flange_T_marker.linear() = so3Exp(Eigen::Vector3d(0.0, 0.5, 0.3));
    flange_T_marker.translation() << 60, 0, 40;
    setup.flange_T_marker = flange_T_marker;
    setup.base_T_tracker = base_T_tracker;
    setup.flange_T_tip.translation() << 0, 0, 150;
    const Eigen::Isometry3d tip0 = arm->state().base_T_flange * setup.flange_T_tip;
    const Eigen::Vector3d dir = (tip0.linear() * Eigen::Vector3d(0.08, -0.05, 1.0)).normalized();
    setup.plan.name = "test";
    setup.plan.entry = tip0.translation() + tip0.linear() * Eigen::Vector3d(8, 5, 45);
    setup.plan.target = setup.plan.entry + 30.0 * dir;
  }

  void build() { loop = std::make_unique<ControlLoop>(arm, kin, setup, options); }

  [[nodiscard]] double now() const { return static_cast<double>(loop ? loop->cycle() : 0) * 0.002; }

  [[nodiscard]] TrackingSnapshot sense() const {
    const ArmState s = arm->state();
    TrackingSnapshot t;
    t.connected = tracker_connected;
    t.time_s = now();
    t.drill_tracked = drill_visible;
    t.drill_timestamp_s = t.time_s - drill_delay_s;
    t.tracker_T_drill = base_T_tracker.inverse() * s.base_T_flange * flange_T_marker;
    t.patient_tracked = patient_visible;
    t.patient_timestamp_s = t.time_s - patient_delay_s;
    t.tracker_T_patient = base_T_tracker.inverse() * base_T_patient;
    return t;
  }

  CycleReport tickAndStep() {
    const CycleReport r = loop->tick(sense(), cycle_time_s, missed);
    arm->step();
    return r;
  }

  /// Ticks until the supervisor is in `state` (true) or max cycles pass (false).
  bool runUntil(SupervisorState state, int max_cycles) {
    for (int k = 0; k < max_cycles; ++k) {
      if (loop->supervisor().state() == state) return true;
      tickAndStep();
    }
    return loop->supervisor().state() == state;
  }

  /// True tip in the base frame.
  [[nodiscard]] Eigen::Isometry3d tip() const { return arm->state().base_T_flange * setup.flange_T_tip; }
};

}  // namespace mrsns::robot::test
