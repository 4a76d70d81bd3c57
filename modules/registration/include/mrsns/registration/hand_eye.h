#pragma once
// Hand-eye calibration: the AX = XB problem and its robot-world variant
// AX = YB. A camera (the "eye") is rigidly mounted on a moving body (the
// "hand": a robot flange, a tracked HMD marker); X = hand_T_eye is unknown.
// Every pair of stations i, j gives a hand motion A and the eye motion B seen
// by the camera against a fixed target, with A X = X B.
//
// Solvers (doc/hand_eye.md has the derivations and the limits):
// - TsaiLenz: modified Rodrigues vectors, linear least squares (Tsai & Lenz
//   1989). Fails when X itself rotates by ~pi (tan(theta/2) diverges).
// - ParkMartin: rotation from the log map, R_X = (M^T M)^-1/2 M^T (Park &
//   Martin 1994); any X, any motion angle.
// - Daniilidis: dual quaternions, rotation and translation together from the
//   null space of one linear system (Daniilidis 1999).
// - Refined: Levenberg-Marquardt over all pairs (rotation and translation
//   residuals, each scaled by its RMS after ParkMartin), started from
//   ParkMartin.
//
// Relative motions are formed from all pairs i < j (as OpenCV does); pairs
// whose hand rotation is below min_rotation_angle_rad are skipped, because
// their rotation axis is noise. Motions whose rotation axes all lie on one
// line leave the translation of X along that line undetermined: refused.
//
// Units: mm and radians. Namespace mrsns (this API is shared with the HMD and
// robot modules).
#include <Eigen/Geometry>
#include <vector>

namespace mrsns {

enum class HandEyeMethod {
  TsaiLenz,
  ParkMartin,
  Daniilidis,
  Refined
};  // Refined = non-linear LM over all pairs started from ParkMartin

struct HandEyeOptions {
  HandEyeMethod method = HandEyeMethod::Refined;
  double min_rotation_angle_rad = 0.05;  // relative motions smaller than this carry no rotation information: skipped
  double min_axis_spread_rad = 0.1;      // rotation axes all within this of one line -> degenerate, refused
};

struct HandEyeResult {
  Eigen::Isometry3d hand_T_eye = Eigen::Isometry3d::Identity();  // X in A X = X B
  double rotation_rms_rad = 0, translation_rms_mm = 0;           // residuals of A X vs X B over the motion pairs
  std::vector<double> pair_rotation_residual_rad, pair_translation_residual_mm;
  int motion_pairs_used = 0;
  /// Conditioning figure: angle-weighted RMS angle of the hand rotation axes from their
  /// principal line (0 = one axis only; ~0.79 rad for two orthogonal axes used equally).
  double axis_spread_rad = 0;
  /// Refined only: Levenberg-Marquardt iterations run.
  int iterations = 0;
};

/// Absolute poses, OpenCV calibrateHandEye convention: base_T_hand[i] (gripper2base),
/// eye_T_target[i] (target2cam), the target fixed in the base frame. Returns hand_T_eye.
/// Throws InvalidArgumentError (< 3 poses, size mismatch, non-finite pose, degenerate motion:
/// rotations about one axis only, or too few motions above min_rotation_angle_rad) with an
/// actionable message.
HandEyeResult calibrateHandEye(const std::vector<Eigen::Isometry3d>& base_T_hand,
                               const std::vector<Eigen::Isometry3d>& eye_T_target, const HandEyeOptions& options = {});

/// Relative motions A_i (hand), B_i (eye), A_i X = X B_i. Needs at least 2 usable motions with
/// non-parallel axes; throws InvalidArgumentError otherwise.
HandEyeResult solveAXXB(const std::vector<Eigen::Isometry3d>& A, const std::vector<Eigen::Isometry3d>& B,
                        const HandEyeOptions& options = {});

/// AX = YB (robot-world/hand-eye): base_T_hand[i] * hand_T_eye = base_T_world * world_T_eye[i];
/// both unknowns together (AX=XB initialisation with options.method, Y by pose averaging, then a
/// joint Levenberg-Marquardt refinement over all poses).
struct RobotWorldHandEyeResult {
  Eigen::Isometry3d hand_T_eye = Eigen::Isometry3d::Identity(), base_T_world = Eigen::Isometry3d::Identity();
  double rotation_rms_rad = 0, translation_rms_mm = 0;
  std::vector<double> pose_translation_residual_mm;
  /// Per pose: angle between base_T_hand * hand_T_eye and base_T_world * world_T_eye (rad).
  std::vector<double> pose_rotation_residual_rad;
  double axis_spread_rad = 0;
};
/// Throws InvalidArgumentError like calibrateHandEye.
RobotWorldHandEyeResult calibrateRobotWorldHandEye(const std::vector<Eigen::Isometry3d>& base_T_hand,
                                                   const std::vector<Eigen::Isometry3d>& world_T_eye,
                                                   const HandEyeOptions& options = {});

/// Name of a method ("tsai-lenz", "park-martin", "daniilidis", "refined").
const char* handEyeMethodName(HandEyeMethod method);

}  // namespace mrsns
