#pragma once
// Rigid-body math on SO(3) and SE(3): hat/vee, exponential and logarithm maps,
// interpolation, distances, and the checks/repairs needed for matrices read
// from files.
//
// Conventions
// - Rotation vectors `phi` (axis * angle, radians) live in so(3); so3Exp and
//   so3Log are inverse for |phi| < pi. At |phi| == pi the logarithm is
//   two-valued; so3Log returns one of the two (deterministically).
// - SE(3) tangent vectors are 6-vectors xi = [rho; phi] (translation part
//   first, as in Sophus and manif): exp(xi) = [R(phi), J_l(phi) * rho; 0 1],
//   where J_l is the left Jacobian of SO(3). rho equals the translation only
//   when phi == 0.
// - Frames follow ARCHITECTURE.md: `a_T_b` maps points from b to a.
//
// Functions that take user data (matrices from files, arrays) validate it and
// throw InvalidArgumentError; the pure math functions assume finite input and
// are cheap enough for real-time loops.
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <array>
#include <span>

namespace mrsns {

using Vector6d = Eigen::Matrix<double, 6, 1>;

/// Skew-symmetric matrix [w]x such that [w]x * v == w.cross(v).
Eigen::Matrix3d so3Hat(const Eigen::Vector3d& w);

/// Inverse of so3Hat; reads the antisymmetric part of W (the symmetric part is ignored).
Eigen::Vector3d so3Vee(const Eigen::Matrix3d& W);

/// Rodrigues' formula; Taylor series below ~1e-5 rad so tiny angles keep full precision.
Eigen::Matrix3d so3Exp(const Eigen::Vector3d& phi);

/// Rotation vector of R with |phi| in [0, pi]. Stable for tiny angles (series) and
/// near pi (axis from the symmetric part, sign from the antisymmetric part).
/// R is assumed orthonormal; use nearestRotation() first for noisy matrices.
Eigen::Vector3d so3Log(const Eigen::Matrix3d& R);

/// Left Jacobian J_l(phi) of SO(3) (the "V" matrix of the SE(3) exponential).
Eigen::Matrix3d so3LeftJacobian(const Eigen::Vector3d& phi);

/// Inverse of so3LeftJacobian; defined for |phi| < 2*pi.
Eigen::Matrix3d so3LeftJacobianInverse(const Eigen::Vector3d& phi);

/// 4x4 matrix of the se(3) element xi = [rho; phi].
Eigen::Matrix4d se3Hat(const Vector6d& xi);

/// SE(3) exponential of xi = [rho; phi] (see the header comment for the convention).
Eigen::Isometry3d se3Exp(const Vector6d& xi);

/// SE(3) logarithm, inverse of se3Exp for |phi| < pi. Returns [rho; phi].
Vector6d se3Log(const Eigen::Isometry3d& T);

/// Rotation angle of R in [0, pi] (atan2 form: accurate near 0 and near pi, unlike acos).
double rotationAngle(const Eigen::Matrix3d& R);

/// Geodesic distance between two rotations: the angle of Ra^T * Rb, in [0, pi].
double rotationAngleBetween(const Eigen::Matrix3d& Ra, const Eigen::Matrix3d& Rb);
double rotationAngleBetween(const Eigen::Quaterniond& qa, const Eigen::Quaterniond& qb);

/// Spherical linear interpolation along the shortest arc: t = 0 gives q0, t = 1 gives q1,
/// constant angular speed in between; t outside [0, 1] extrapolates along the same arc.
/// Inputs need not be normalised; the result is unit. Throws InvalidArgumentError on NaN t
/// or a zero/NaN quaternion.
Eigen::Quaterniond slerp(const Eigen::Quaterniond& q0, const Eigen::Quaterniond& q1, double t);

/// Same as the quaternion slerp for rotation matrices: R0 * exp(t * log(R0^T R1)).
Eigen::Matrix3d slerp(const Eigen::Matrix3d& R0, const Eigen::Matrix3d& R1, double t);

/// Pose between a (t = 0) and b (t = 1): slerp of the rotations and linear interpolation of the
/// translations (the usual tracking-buffer interpolation, as in PLUS). t outside [0, 1]
/// extrapolates. Throws InvalidArgumentError on NaN t.
Eigen::Isometry3d interpolatePose(const Eigen::Isometry3d& a, const Eigen::Isometry3d& b, double t);

/// True when M is finite, its bottom row is [0 0 0 1] within tol, its 3x3 block R satisfies
/// |R^T R - I|_max <= tol and det(R) > 0.
bool isRigid(const Eigen::Matrix4d& M, double tol = 1e-6);

/// Closest rotation (Frobenius norm) to A, by SVD. Throws InvalidArgumentError when A is not
/// finite, is (nearly) singular or is a reflection (det(A) < 0).
Eigen::Matrix3d nearestRotation(const Eigen::Matrix3d& A);

/// Rigid transform closest to M: nearestRotation() of the 3x3 block and M's translation.
/// For matrices read from files that were printed with few digits. Throws
/// InvalidArgumentError when M is not finite, its bottom row is not [0 0 0 1] (within 1e-6)
/// or its rotation block is singular or a reflection.
Eigen::Isometry3d orthonormalize(const Eigen::Matrix4d& M);

/// 4x4 matrix from 16 values in row-major order (the order of PLUS files and OpenIGTLink
/// text). Throws InvalidArgumentError on a non-finite value.
Eigen::Matrix4d matrixFromRowMajor(std::span<const double, 16> values);

/// Isometry from 16 row-major values. Throws InvalidArgumentError when a value is not
/// finite or the matrix is not rigid within tol (call orthonormalize() on
/// matrixFromRowMajor() to accept slightly non-orthonormal input on purpose).
Eigen::Isometry3d isometryFromRowMajor(std::span<const double, 16> values, double tol = 1e-6);

/// The 16 values of T's 4x4 matrix in row-major order.
std::array<double, 16> toRowMajor(const Eigen::Isometry3d& T);

}  // namespace mrsns
