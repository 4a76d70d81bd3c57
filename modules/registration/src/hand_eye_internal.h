#pragma once
// Solvers behind hand_eye.h, on relative motions already filtered (every
// motion rotates by more than the minimum angle).
#include <Eigen/Geometry>
#include <vector>

namespace mrsns::hand_eye_detail {

using Poses = std::vector<Eigen::Isometry3d>;

/// Translation of X given its rotation: stacked (R_A - I) t = R t_B - t_A, least squares.
Eigen::Vector3d translationLeastSquares(const Poses& A, const Poses& B, const Eigen::Matrix3d& R);

Eigen::Isometry3d solveTsaiLenz(const Poses& A, const Poses& B);
Eigen::Isometry3d solveParkMartin(const Poses& A, const Poses& B);
/// rotation_hint (e.g. from ParkMartin) only picks the quaternion sign of motions near pi,
/// where the scalar parts cannot.
Eigen::Isometry3d solveDaniilidis(const Poses& A, const Poses& B, const Eigen::Matrix3d& rotation_hint);

/// Levenberg-Marquardt on the 6 parameters of X; returns the iterations run.
int refineAXXB(const Poses& A, const Poses& B, Eigen::Isometry3d& X);

/// Joint Levenberg-Marquardt on X and Y for H_i X = Y W_i.
void refineAXYB(const Poses& H, const Poses& W, Eigen::Isometry3d& X, Eigen::Isometry3d& Y);

/// Angle-weighted RMS angle of the rotation axes of the motions from their principal line.
double axisSpread(const Poses& motions);

}  // namespace mrsns::hand_eye_detail
