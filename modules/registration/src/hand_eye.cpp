// Input checks, motion-pair formation and method dispatch for hand_eye.h.
#include "mrsns/registration/hand_eye.h"

#include <cmath>
#include <string>

#include "hand_eye_internal.h"
#include "mrsns/core/error.h"
#include "mrsns/core/format.h"
#include "mrsns/core/rigid.h"
#include "mrsns/core/rotation_average.h"

namespace mrsns {
namespace {

using hand_eye_detail::Poses;
constexpr double kRadToDeg = 180.0 / 3.14159265358979323846;

std::string deg(double rad) {
  return formatFixed(rad * kRadToDeg, 1);
}

// Finite and rigid (within what a float file or a tracker SDK prints), then projected onto SE(3).
Poses checkedPoses(const Poses& poses, const char* name) {
  Poses out;
  out.reserve(poses.size());
  for (size_t i = 0; i < poses.size(); ++i) {
    if (!isRigid(poses[i].matrix(), 1e-4)) {
      throw InvalidArgumentError(std::string(name) + "[" + std::to_string(i) +
                                 "] is not a rigid transform (non-finite values or a rotation block that is not "
                                 "orthonormal): pass tracker poses as rotations and translations in mm");
    }
    out.push_back(orthonormalize(poses[i].matrix()));
  }
  return out;
}

void checkSizes(size_t a, size_t b, const char* name_a, const char* name_b, size_t minimum) {
  if (a != b) {
    throw InvalidArgumentError(std::string(name_a) + " has " + std::to_string(a) + " poses but " + name_b + " has " +
                               std::to_string(b) + ": give one pair per station, in the same order");
  }
  if (a < minimum) {
    throw InvalidArgumentError(std::string(name_a) + " has " + std::to_string(a) +
                               " poses; hand-eye calibration needs at least " + std::to_string(minimum) +
                               " stations rotated about two different axes");
  }
}

struct UsedMotions {
  Poses A, B;
};

UsedMotions usableMotions(const Poses& A, const Poses& B, const HandEyeOptions& options) {
  UsedMotions used;
  for (size_t i = 0; i < A.size(); ++i) {
    const double angle = std::min(rotationAngle(A[i].linear()), rotationAngle(B[i].linear()));
    if (angle >= options.min_rotation_angle_rad) {
      used.A.push_back(A[i]);
      used.B.push_back(B[i]);
    }
  }
  if (used.A.size() < 2) {
    throw InvalidArgumentError("only " + std::to_string(used.A.size()) + " of " + std::to_string(A.size()) +
                               " hand-eye motions rotate by more than " + deg(options.min_rotation_angle_rad) +
                               " deg (min_rotation_angle_rad): rotate the hand by at least that much between "
                               "stations, about two different axes");
  }
  const double spread = hand_eye_detail::axisSpread(used.A);
  if (spread < options.min_axis_spread_rad) {
    throw InvalidArgumentError("degenerate hand-eye motion: the rotation axes of all " + std::to_string(used.A.size()) +
                               " motions lie within " + deg(spread) + " deg of one line (need " +
                               deg(options.min_axis_spread_rad) +
                               " deg, min_axis_spread_rad), so the translation along that axis is undetermined: "
                               "add stations rotated about a second, different axis");
  }
  return used;
}

Eigen::Isometry3d solve(const Poses& A, const Poses& B, HandEyeMethod method, int& iterations) {
  iterations = 0;
  switch (method) {
    case HandEyeMethod::TsaiLenz: return hand_eye_detail::solveTsaiLenz(A, B);
    case HandEyeMethod::ParkMartin: return hand_eye_detail::solveParkMartin(A, B);
    case HandEyeMethod::Daniilidis:
      return hand_eye_detail::solveDaniilidis(A, B, hand_eye_detail::solveParkMartin(A, B).linear());
    case HandEyeMethod::Refined: {
      Eigen::Isometry3d X = hand_eye_detail::solveParkMartin(A, B);
      iterations = hand_eye_detail::refineAXXB(A, B, X);
      return X;
    }
  }
  throw InvalidArgumentError("unknown HandEyeMethod value " + std::to_string(static_cast<int>(method)));
}

double rms(const std::vector<double>& v) {
  double s = 0.0;
  for (double x : v) s += x * x;
  return v.empty() ? 0.0 : std::sqrt(s / static_cast<double>(v.size()));
}

HandEyeResult solveChecked(const Poses& A, const Poses& B, const HandEyeOptions& options) {
  const UsedMotions used = usableMotions(A, B, options);
  HandEyeResult result;
  result.axis_spread_rad = hand_eye_detail::axisSpread(used.A);
  result.motion_pairs_used = static_cast<int>(used.A.size());
  result.hand_T_eye = solve(used.A, used.B, options.method, result.iterations);
  for (size_t i = 0; i < used.A.size(); ++i) {
    const Eigen::Isometry3d lhs = used.A[i] * result.hand_T_eye, rhs = result.hand_T_eye * used.B[i];
    result.pair_rotation_residual_rad.push_back(rotationAngleBetween(lhs.linear(), rhs.linear()));
    result.pair_translation_residual_mm.push_back((lhs.translation() - rhs.translation()).norm());
  }
  result.rotation_rms_rad = rms(result.pair_rotation_residual_rad);
  result.translation_rms_mm = rms(result.pair_translation_residual_mm);
  return result;
}

}  // namespace

const char* handEyeMethodName(HandEyeMethod method) {
  switch (method) {
    case HandEyeMethod::TsaiLenz: return "tsai-lenz";
    case HandEyeMethod::ParkMartin: return "park-martin";
    case HandEyeMethod::Daniilidis: return "daniilidis";
    case HandEyeMethod::Refined: return "refined";
  }
  return "unknown";
}

HandEyeResult solveAXXB(const std::vector<Eigen::Isometry3d>& A, const std::vector<Eigen::Isometry3d>& B,
                        const HandEyeOptions& options) {
  checkSizes(A.size(), B.size(), "A (hand motions)", "B (eye motions)", 2);
  return solveChecked(checkedPoses(A, "A"), checkedPoses(B, "B"), options);
}

HandEyeResult calibrateHandEye(const std::vector<Eigen::Isometry3d>& base_T_hand,
                               const std::vector<Eigen::Isometry3d>& eye_T_target, const HandEyeOptions& options) {
  checkSizes(base_T_hand.size(), eye_T_target.size(), "base_T_hand", "eye_T_target", 3);
  const Poses H = checkedPoses(base_T_hand, "base_T_hand");
  const Poses E = checkedPoses(eye_T_target, "eye_T_target");
  // base_T_target = H_i X E_i for every i, so (H_j^-1 H_i) X = X (E_j E_i^-1).
  Poses A, B;
  for (size_t i = 0; i < H.size(); ++i) {
    for (size_t j = i + 1; j < H.size(); ++j) {
      A.push_back(H[j].inverse() * H[i]);
      B.push_back(E[j] * E[i].inverse());
    }
  }
  return solveChecked(A, B, options);
}

RobotWorldHandEyeResult calibrateRobotWorldHandEye(const std::vector<Eigen::Isometry3d>& base_T_hand,
                                                   const std::vector<Eigen::Isometry3d>& world_T_eye,
                                                   const HandEyeOptions& options) {
  checkSizes(base_T_hand.size(), world_T_eye.size(), "base_T_hand", "world_T_eye", 3);
  const Poses H = checkedPoses(base_T_hand, "base_T_hand");
  const Poses W = checkedPoses(world_T_eye, "world_T_eye");
  // H_i X = Y W_i, so Y = H_i X W_i^-1 for every i and (H_j^-1 H_i) X = X (W_j^-1 W_i).
  Poses A, B;
  for (size_t i = 0; i < H.size(); ++i) {
    for (size_t j = i + 1; j < H.size(); ++j) {
      A.push_back(H[j].inverse() * H[i]);
      B.push_back(W[j].inverse() * W[i]);
    }
  }
  const HandEyeResult axxb = solveChecked(A, B, options);
  RobotWorldHandEyeResult result;
  result.axis_spread_rad = axxb.axis_spread_rad;
  result.hand_T_eye = axxb.hand_T_eye;
  Poses Y_estimates;
  for (size_t i = 0; i < H.size(); ++i) Y_estimates.push_back(H[i] * result.hand_T_eye * W[i].inverse());
  result.base_T_world = averagePoses(Y_estimates).mean;
  if (options.method == HandEyeMethod::Refined) {
    hand_eye_detail::refineAXYB(H, W, result.hand_T_eye, result.base_T_world);
  }
  for (size_t i = 0; i < H.size(); ++i) {
    const Eigen::Isometry3d lhs = H[i] * result.hand_T_eye, rhs = result.base_T_world * W[i];
    result.pose_rotation_residual_rad.push_back(rotationAngleBetween(lhs.linear(), rhs.linear()));
    result.pose_translation_residual_mm.push_back((lhs.translation() - rhs.translation()).norm());
  }
  result.rotation_rms_rad = rms(result.pose_rotation_residual_rad);
  result.translation_rms_mm = rms(result.pose_translation_residual_mm);
  return result;
}

}  // namespace mrsns
