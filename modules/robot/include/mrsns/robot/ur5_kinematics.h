#pragma once
// UR5 kinematics in the standard Denavit-Hartenberg convention Universal Robots publishes
// (link i: Rz(theta_i) Tz(d_i) Tx(a_i) Rx(alpha_i)): forward kinematics, the analytic inverse with all
// eight solutions (Hawkins 2013, "Analytic inverse kinematics for the Universal Robots UR-5/UR-10
// arms"), the geometric Jacobian, singularity and joint-limit checks. Lengths in mm, angles in rad.
#include <Eigen/Geometry>
#include <array>
#include <optional>
#include <string>
#include <vector>

#include "mrsns/robot/robot_arm.h"

namespace mrsns::robot {

struct DhParameters {
  std::array<double, 6> d{};      ///< mm
  std::array<double, 6> a{};      ///< mm
  std::array<double, 6> alpha{};  ///< rad
};

/// The UR family's DH table from its six non-zero lengths (mm): d1, a2, a3, d4, d5, d6 (alpha is
/// pi/2, 0, 0, pi/2, -pi/2, 0 for every UR arm). Throws InvalidArgumentError when a value is not finite,
/// a2/a3 are not negative (UR sign convention) or d1, d4, d5, d6 are not positive.
DhParameters urDhParameters(double d1, double a2, double a3, double d4, double d5, double d6);

/// Nominal UR5 (CB3): d1 = 89.159, a2 = -425, a3 = -392.25, d4 = 109.15, d5 = 94.65, d6 = 82.3 mm.
DhParameters ur5DhParameters();

struct JointLimits {
  Joints min_q = Joints::Constant(-2.0 * 3.14159265358979323846);
  Joints max_q = Joints::Constant(2.0 * 3.14159265358979323846);
  Joints max_qd = Joints::Constant(3.14159265358979323846);  ///< rad/s
  Joints max_qdd = Joints::Constant(15.0);                   ///< rad/s^2
};

/// UR5 limits: positions +-2 pi except the elbow (+-pi, the arm's own geometry), speed pi rad/s for
/// every joint (ur5_joint_limits.yaml of ur_description, from the UR5 user manual), acceleration
/// 15 rad/s^2 (not published; the default of the UR teach pendant's joint moves is 1.4, its speedj
/// limit is ~40, 15 is a conservative value within both).
JointLimits ur5JointLimits();

/// True when every joint is within [min_q, max_q].
bool withinLimits(const Joints& q, const JointLimits& limits);

/// Index of the first joint outside its limits, or -1.
int firstJointOutsideLimits(const Joints& q, const JointLimits& limits);

struct SingularityThresholds {
  double wrist_sin = 0.05;    ///< |sin q5| below: wrist axes 4 and 6 align
  double elbow_sin = 0.05;    ///< |sin q3| below: arm stretched or folded
  double shoulder_mm = 10.0;  ///< wrist point this close to the shoulder axis plane
};

struct SingularityReport {
  bool wrist = false;
  bool elbow = false;
  bool shoulder = false;
  double wrist_sin = 0;    ///< sin q5
  double elbow_sin = 0;    ///< sin q3
  double shoulder_mm = 0;  ///< a2 cos q2 + a3 cos(q2 + q3) + d5 sin(q2 + q3 + q4)
  /// Smallest singular value of the Jacobian with the linear rows in m (so both halves weigh alike).
  double min_singular_value = 0;
  [[nodiscard]] bool any() const { return wrist || elbow || shoulder; }
};

class Ur5Kinematics {
 public:
  /// Throws InvalidArgumentError for non-finite parameters.
  explicit Ur5Kinematics(const DhParameters& dh = ur5DhParameters());

  [[nodiscard]] const DhParameters& dh() const { return dh_; }

  /// base_T_flange for joints q.
  [[nodiscard]] Eigen::Isometry3d forward(const Joints& q) const;

  /// base_T_link_i for i = 0..6 (0 is the identity, 6 the flange).
  [[nodiscard]] std::array<Eigen::Isometry3d, 7> forwardFrames(const Joints& q) const;

  /// Every solution (up to 8) for base_T_flange, each joint in (-pi, pi]. Empty when the pose is out of
  /// reach. At the wrist singularity (sin q5 ~ 0) q6 is free and set to `q6_hint`.
  [[nodiscard]] std::vector<Joints> inverse(const Eigen::Isometry3d& base_T_flange, double q6_hint = 0.0) const;

  /// The solution nearest to `q_current` (each joint unwrapped by multiples of 2 pi to the branch nearest
  /// the current value, then largest joint step minimised), restricted to solutions within `limits`
  /// when given. nullopt when none exists.
  [[nodiscard]] std::optional<Joints> inverseNearest(const Eigen::Isometry3d& base_T_flange, const Joints& q_current,
                                                     const JointLimits* limits = nullptr) const;

  /// Geometric Jacobian in the base frame: [v (mm/s); w (rad/s)] of the flange = J * qd.
  [[nodiscard]] Eigen::Matrix<double, 6, 6> jacobian(const Joints& q) const;

  [[nodiscard]] SingularityReport singularity(const Joints& q, const SingularityThresholds& thresholds = {}) const;

 private:
  [[nodiscard]] Eigen::Isometry3d link(int i, double theta) const;
  DhParameters dh_;
};

}  // namespace mrsns::robot
