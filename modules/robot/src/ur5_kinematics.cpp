#include "mrsns/robot/ur5_kinematics.h"

#include <cmath>
#include <numbers>
#include <string>

#include "mrsns/core/dense_solvers.h"
#include "mrsns/core/error.h"
#include "mrsns/core/units.h"

namespace mrsns::robot {
namespace {

double wrapAngle(double x) {
  x = std::remainder(x, 2.0 * kPi);
  return x <= -kPi ? x + 2.0 * kPi : x;
}

// acos that tolerates rounding just outside [-1, 1] (a pose exactly at the boundary of the workspace).
bool safeAcos(double c, double& out) {
  constexpr double kSlack = 1e-10;
  if (!std::isfinite(c) || std::abs(c) > 1.0 + kSlack) return false;
  out = std::acos(std::clamp(c, -1.0, 1.0));
  return true;
}

}  // namespace

DhParameters urDhParameters(double d1, double a2, double a3, double d4, double d5, double d6) {
  const std::array<double, 6> v{d1, a2, a3, d4, d5, d6};
  for (double x : v) {
    if (!std::isfinite(x))
      throw InvalidArgumentError("urDhParameters: a DH length is not finite; pass six numbers in mm");
  }
  if (a2 >= 0 || a3 >= 0) {
    throw InvalidArgumentError("urDhParameters: a2 and a3 must be negative (Universal Robots' sign convention), got " +
                               std::to_string(a2) + ", " + std::to_string(a3) + " mm");
  }
  if (d1 <= 0 || d4 <= 0 || d5 <= 0 || d6 <= 0) {
    throw InvalidArgumentError("urDhParameters: d1, d4, d5, d6 must be positive lengths in mm");
  }
  DhParameters dh;
  dh.d = {d1, 0, 0, d4, d5, d6};
  dh.a = {0, a2, a3, 0, 0, 0};
  dh.alpha = {kPi / 2, 0, 0, kPi / 2, -kPi / 2, 0};
  return dh;
}

DhParameters ur5DhParameters() {
  return urDhParameters(89.159, -425.0, -392.25, 109.15, 94.65, 82.3);
}

JointLimits ur5JointLimits() {
  JointLimits l;
  l.min_q = Joints::Constant(-2.0 * kPi);
  l.max_q = Joints::Constant(2.0 * kPi);
  l.min_q[2] = -kPi;
  l.max_q[2] = kPi;
  l.max_qd = Joints::Constant(kPi);
  l.max_qdd = Joints::Constant(15.0);
  return l;
}

int firstJointOutsideLimits(const Joints& q, const JointLimits& limits) {
  for (int i = 0; i < 6; ++i) {
    if (!(q[i] >= limits.min_q[i] && q[i] <= limits.max_q[i])) return i;
  }
  return -1;
}

bool withinLimits(const Joints& q, const JointLimits& limits) {
  return firstJointOutsideLimits(q, limits) < 0;
}

Ur5Kinematics::Ur5Kinematics(const DhParameters& dh) : dh_(dh) {
  for (int i = 0; i < 6; ++i) {
    if (!std::isfinite(dh.d[i]) || !std::isfinite(dh.a[i]) || !std::isfinite(dh.alpha[i])) {
      throw InvalidArgumentError("Ur5Kinematics: DH parameter of link " + std::to_string(i + 1) + " is not finite");
    }
  }
}

Eigen::Isometry3d Ur5Kinematics::link(int i, double theta) const {
  const double ct = std::cos(theta), st = std::sin(theta);
  const double ca = std::cos(dh_.alpha[i]), sa = std::sin(dh_.alpha[i]);
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() << ct, -st * ca, st * sa, st, ct * ca, -ct * sa, 0, sa, ca;
  T.translation() << dh_.a[i] * ct, dh_.a[i] * st, dh_.d[i];
  return T;
}

std::array<Eigen::Isometry3d, 7> Ur5Kinematics::forwardFrames(const Joints& q) const {
  std::array<Eigen::Isometry3d, 7> frames;
  frames[0] = Eigen::Isometry3d::Identity();
  for (int i = 0; i < 6; ++i) frames[i + 1] = frames[i] * link(i, q[i]);
  return frames;
}

Eigen::Isometry3d Ur5Kinematics::forward(const Joints& q) const {
  return forwardFrames(q)[6];
}

std::vector<Joints> Ur5Kinematics::inverse(const Eigen::Isometry3d& T06, double q6_hint) const {
  std::vector<Joints> out;
  if (!T06.matrix().allFinite()) return out;
  const double a2 = dh_.a[1], a3 = dh_.a[2], d4 = dh_.d[3], d6 = dh_.d[5];
  // Wrist point (origin of frame 5): back from the flange along its z axis.
  const Eigen::Vector3d p05 = T06 * Eigen::Vector3d(0, 0, -d6);
  const double r05 = std::hypot(p05.x(), p05.y());
  double phi2 = 0;
  if (r05 < 1e-12 || !safeAcos(d4 / r05, phi2)) return out;  // wrist point inside the shoulder cylinder
  const double phi1 = std::atan2(p05.y(), p05.x());
  const Eigen::Isometry3d T60 = T06.inverse();
  const Eigen::Vector3d p06 = T06.translation();
  for (int s1 : {1, -1}) {
    const double q1 = phi1 + s1 * phi2 + kPi / 2;
    const double s_1 = std::sin(q1), c_1 = std::cos(q1);
    double q5abs = 0;
    if (!safeAcos((p06.x() * s_1 - p06.y() * c_1 - d4) / d6, q5abs)) continue;
    for (int s5 : {1, -1}) {
      const double q5 = s5 * q5abs;
      const double s_5 = std::sin(q5);
      double q6 = q6_hint;
      if (std::abs(s_5) > 1e-10) {
        // x and y axes of the base frame seen from the flange.
        const Eigen::Vector3d x60 = T60.linear().col(0), y60 = T60.linear().col(1);
        q6 = std::atan2((-x60.y() * s_1 + y60.y() * c_1) / s_5, (x60.x() * s_1 - y60.x() * c_1) / s_5);
      }
      // Frames 1..4 form a planar 3R chain: solve it in frame 1.
      const Eigen::Isometry3d T01 = link(0, q1);
      const Eigen::Isometry3d T46 = link(4, q5) * link(5, q6);
      const Eigen::Isometry3d T14 = T01.inverse() * T06 * T46.inverse();
      // In frame 1 the origin of frame 4 is (a2 c2 + a3 c23, a2 s2 + a3 s23, d4): a planar 2R problem.
      const Eigen::Vector3d p14 = T14.translation();
      const double r14sq = p14.x() * p14.x() + p14.y() * p14.y();
      double q3abs = 0;
      if (!safeAcos((r14sq - a2 * a2 - a3 * a3) / (2 * a2 * a3), q3abs)) continue;
      for (int s3 : {1, -1}) {
        const double q3 = s3 * q3abs;
        const double q2 = std::atan2(p14.y(), p14.x()) - std::atan2(a3 * std::sin(q3), a2 + a3 * std::cos(q3));
        const Eigen::Isometry3d T13 = link(1, q2) * link(2, q3);
        const Eigen::Isometry3d T34 = T13.inverse() * T14;
        const double q4 = std::atan2(T34.linear()(1, 0), T34.linear()(0, 0));
        Joints q;
        q << q1, q2, q3, q4, q5, q6;
        for (int i = 0; i < 6; ++i) q[i] = wrapAngle(q[i]);
        out.push_back(q);
      }
    }
  }
  return out;
}

std::optional<Joints> Ur5Kinematics::inverseNearest(const Eigen::Isometry3d& base_T_flange, const Joints& q_current,
                                                    const JointLimits* limits) const {
  const auto solutions = inverse(base_T_flange, q_current[5]);
  std::optional<Joints> best;
  double best_cost = std::numeric_limits<double>::infinity();
  for (Joints q : solutions) {
    // Joints turn more than once around: take the turn nearest to where the joint is now.
    for (int i = 0; i < 6; ++i) q[i] = q_current[i] + wrapAngle(q[i] - q_current[i]);
    if (limits != nullptr && !withinLimits(q, *limits)) continue;
    const double cost = (q - q_current).cwiseAbs().maxCoeff() + 1e-3 * (q - q_current).norm();
    if (cost < best_cost) {
      best_cost = cost;
      best = q;
    }
  }
  return best;
}

Eigen::Matrix<double, 6, 6> Ur5Kinematics::jacobian(const Joints& q) const {
  const auto frames = forwardFrames(q);
  const Eigen::Vector3d pe = frames[6].translation();
  Eigen::Matrix<double, 6, 6> J;
  for (int i = 0; i < 6; ++i) {
    const Eigen::Vector3d z = frames[i].linear().col(2);
    J.block<3, 1>(0, i) = z.cross(pe - frames[i].translation());
    J.block<3, 1>(3, i) = z;
  }
  return J;
}

SingularityReport Ur5Kinematics::singularity(const Joints& q, const SingularityThresholds& t) const {
  SingularityReport r;
  const double a2 = dh_.a[1], a3 = dh_.a[2], d5 = dh_.d[4];
  r.wrist_sin = std::sin(q[4]);
  r.elbow_sin = std::sin(q[2]);
  // det J = a2 a3 d... s3 s5 (a2 c2 + a3 c23 + d5 s234): the last factor is the distance of the wrist
  // from the plane through the shoulder axis (the two q1 branches meet there).
  r.shoulder_mm = a2 * std::cos(q[1]) + a3 * std::cos(q[1] + q[2]) + d5 * std::sin(q[1] + q[2] + q[3]);
  r.wrist = std::abs(r.wrist_sin) < t.wrist_sin;
  r.elbow = std::abs(r.elbow_sin) < t.elbow_sin;
  r.shoulder = std::abs(r.shoulder_mm) < t.shoulder_mm;
  // Dynamic size: GCC 12 warns (falsely) about the fixed-size JacobiSVD's storage.
  Eigen::MatrixXd J = jacobian(q);
  J.topRows(3) *= 1e-3;
  r.min_singular_value = thinSvd(J, SvdVectors::kNone).singular_values.minCoeff();
  return r;
}

}  // namespace mrsns::robot
