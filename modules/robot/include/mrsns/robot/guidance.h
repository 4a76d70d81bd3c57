#pragma once
// Guidance along a planned screw axis, in the robot base frame: approach and align the drill to a
// stand-off point on the axis, advance along it (robot-driven at a set speed, or the surgeon's
// hand-guiding constrained to the axis), retract. Each update yields the joint target of the next
// control cycle (IK nearest the current joints) for servoJ.
#include <Eigen/Geometry>

#include "mrsns/robot/robot_arm.h"
#include "mrsns/robot/ur5_kinematics.h"

namespace mrsns::robot {

enum class GuidancePhase { Idle, Approach, Advance, Retract, Done };
enum class AdvanceMode { RobotDriven, HandGuided };

const char* toString(GuidancePhase phase);

struct GuidanceOptions {
  double standoff_mm = 20.0;  ///< the approach ends this far before the entry, on the axis
  double approach_speed_mm_s = 40.0;
  double approach_rotation_speed_rad_s = 0.25;
  double approach_acceleration_mm_s2 = 100.0;
  double approach_angular_acceleration_rad_s2 = 1.0;
  double align_tolerance_mm = 0.2;  ///< commanded tip to stand-off point
  double align_tolerance_rad = 0.004;
  int align_settle_cycles = 100;  ///< the tolerance must hold this long (the axis estimate is filtered)
  double advance_speed_mm_s = 5.0;
  double retract_speed_mm_s = 20.0;
  double depth_mm = 0.0;  ///< how deep past the entry; <= 0: to the planned length
  AdvanceMode mode = AdvanceMode::RobotDriven;
  double max_hand_speed_mm_s = 5.0;  ///< hand-guided advance is clamped to this
  JointLimits limits = ur5JointLimits();
};

/// The planned axis in the robot base for this cycle.
struct AxisInBase {
  Eigen::Vector3d entry = Eigen::Vector3d::Zero();
  Eigen::Vector3d direction = Eigen::Vector3d::UnitZ();  ///< unit, drilling direction
  double length_mm = 0;
};

struct GuidanceCommand {
  bool has_target = false;  ///< false: hold (send nothing)
  Joints q = Joints::Zero();
  GuidancePhase phase = GuidancePhase::Idle;
  double depth_mm = 0;   ///< commanded tip depth past the entry (negative: before it)
  bool aligned = false;  ///< the approach just finished (this cycle)
  bool done = false;     ///< the retraction just finished (this cycle)
  bool ik_failed = false;
};

/// The part of a hand-guiding twist that moves along `direction`: the surgeon can push the drill in or
/// pull it back, never sideways or tilted.
Twist constrainToAxis(const Twist& hand, const Eigen::Vector3d& direction);

class Guidance {
 public:
  /// Throws InvalidArgumentError for non-positive speeds or tolerances.
  Guidance(const Ur5Kinematics& kinematics, const Eigen::Isometry3d& flange_T_tip, const GuidanceOptions& options = {});

  /// Starts the approach from the arm's current pose.
  void start(const ArmState& arm);
  /// Retracts from wherever the advance is.
  void retract();
  void reset() { phase_ = GuidancePhase::Idle; }

  /// One cycle. `hand` is the surgeon's hand twist (base frame; HandGuided mode only).
  GuidanceCommand update(const ArmState& arm, const AxisInBase& axis, double dt_s, const Twist& hand = Twist::Zero());

  [[nodiscard]] GuidancePhase phase() const { return phase_; }
  [[nodiscard]] double depth() const { return depth_; }
  [[nodiscard]] const Eigen::Isometry3d& flangeTTip() const { return flange_T_tip_; }
  [[nodiscard]] const GuidanceOptions& options() const { return options_; }

 private:
  [[nodiscard]] Eigen::Isometry3d tipPoseOnAxis(const AxisInBase& axis, double depth) const;

  const Ur5Kinematics& kinematics_;
  Eigen::Isometry3d flange_T_tip_;
  GuidanceOptions options_;
  GuidancePhase phase_ = GuidancePhase::Idle;
  Eigen::Isometry3d commanded_tip_ = Eigen::Isometry3d::Identity();  // base_T_tip being commanded
  double depth_ = 0;
  int settled_ = 0;
  double linear_speed_ = 0;   // approach profile, mm/s
  double angular_speed_ = 0;  // approach profile, rad/s
};

}  // namespace mrsns::robot
