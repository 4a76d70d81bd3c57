#include "mrsns/core/rigid.h"

#include <Eigen/SVD>
#include <cmath>
#include <sstream>
#include <string>

#include "mrsns/core/error.h"

namespace mrsns {
namespace {

// Below this angle the closed forms lose digits to cancellation (1 - cos, theta - sin) or
// divide 0 by 0; the truncated series are exact to double precision there.
constexpr double kSmallAngle = 1e-4;

std::string matrixText(const Eigen::Matrix4d& M) {
  std::ostringstream out;
  const Eigen::IOFormat fmt(Eigen::StreamPrecision, Eigen::DontAlignCols, " ", "; ", "", "", "[", "]");
  out << M.format(fmt);
  return out.str();
}

}  // namespace

Eigen::Matrix3d so3Hat(const Eigen::Vector3d& w) {
  Eigen::Matrix3d W;
  W << 0.0, -w.z(), w.y(),  //
      w.z(), 0.0, -w.x(),   //
      -w.y(), w.x(), 0.0;
  return W;
}

Eigen::Vector3d so3Vee(const Eigen::Matrix3d& W) {
  return 0.5 * Eigen::Vector3d(W(2, 1) - W(1, 2), W(0, 2) - W(2, 0), W(1, 0) - W(0, 1));
}

Eigen::Matrix3d so3Exp(const Eigen::Vector3d& phi) {
  const double theta2 = phi.squaredNorm();
  const double theta = std::sqrt(theta2);
  const Eigen::Matrix3d K = so3Hat(phi);
  double a = 0.0;  // sin(theta) / theta
  double b = 0.0;  // (1 - cos(theta)) / theta^2
  if (theta < kSmallAngle) {
    a = 1.0 - theta2 / 6.0;
    b = 0.5 - theta2 / 24.0;
  } else {
    const double half_sin = std::sin(0.5 * theta);
    a = std::sin(theta) / theta;
    b = 2.0 * half_sin * half_sin / theta2;  // 1 - cos without cancellation
  }
  return Eigen::Matrix3d::Identity() + a * K + b * K * K;
}

Eigen::Vector3d so3Log(const Eigen::Matrix3d& R) {
  const Eigen::Vector3d s_axis = so3Vee(R);  // sin(theta) * axis
  const double s = s_axis.norm();
  const double c = 0.5 * (R.trace() - 1.0);
  const double theta = std::atan2(s, c);
  if (theta < kSmallAngle) {
    return (1.0 + s * s / 6.0) * s_axis;  // theta / sin(theta) ~ 1 + theta^2 / 6
  }
  if (c > -0.9) {
    return (theta / s) * s_axis;
  }
  // Near pi, sin(theta) carries too few digits to give the axis. The symmetric part,
  // (R + R^T) / 2 - cos(theta) I = (1 - cos(theta)) k k^T, gives it up to sign; its
  // largest column is the best conditioned. The sign comes from sin(theta) * k, which
  // still has the right sign down to a few ulp; at exactly pi both signs are valid.
  const Eigen::Matrix3d B = 0.5 * (R + R.transpose()) - c * Eigen::Matrix3d::Identity();
  Eigen::Index i = 0;
  B.diagonal().maxCoeff(&i);
  Eigen::Vector3d axis = B.col(i).normalized();
  if (axis.dot(s_axis) < 0.0) axis = -axis;
  return theta * axis;
}

Eigen::Matrix3d so3LeftJacobian(const Eigen::Vector3d& phi) {
  const double theta2 = phi.squaredNorm();
  const double theta = std::sqrt(theta2);
  const Eigen::Matrix3d K = so3Hat(phi);
  double b = 0.0;  // (1 - cos) / theta^2
  double c = 0.0;  // (theta - sin) / theta^3
  if (theta < kSmallAngle) {
    b = 0.5 - theta2 / 24.0;
    c = 1.0 / 6.0 - theta2 / 120.0;
  } else {
    const double half_sin = std::sin(0.5 * theta);
    b = 2.0 * half_sin * half_sin / theta2;
    c = (theta - std::sin(theta)) / (theta2 * theta);
  }
  return Eigen::Matrix3d::Identity() + b * K + c * K * K;
}

Eigen::Matrix3d so3LeftJacobianInverse(const Eigen::Vector3d& phi) {
  const double theta2 = phi.squaredNorm();
  const double theta = std::sqrt(theta2);
  const Eigen::Matrix3d K = so3Hat(phi);
  double d = 0.0;  // (1 - (theta/2) cot(theta/2)) / theta^2, finite at pi unlike the sin form
  if (theta < kSmallAngle) {
    d = 1.0 / 12.0 + theta2 / 720.0;
  } else {
    const double half = 0.5 * theta;
    d = (1.0 - half * std::cos(half) / std::sin(half)) / theta2;
  }
  return Eigen::Matrix3d::Identity() - 0.5 * K + d * K * K;
}

Eigen::Matrix4d se3Hat(const Vector6d& xi) {
  Eigen::Matrix4d X = Eigen::Matrix4d::Zero();
  X.topLeftCorner<3, 3>() = so3Hat(xi.tail<3>());
  X.topRightCorner<3, 1>() = xi.head<3>();
  return X;
}

Eigen::Isometry3d se3Exp(const Vector6d& xi) {
  const Eigen::Vector3d rho = xi.head<3>();
  const Eigen::Vector3d phi = xi.tail<3>();
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = so3Exp(phi);
  T.translation() = so3LeftJacobian(phi) * rho;
  return T;
}

Vector6d se3Log(const Eigen::Isometry3d& T) {
  const Eigen::Vector3d phi = so3Log(T.linear());
  Vector6d xi;
  xi.head<3>() = so3LeftJacobianInverse(phi) * T.translation();
  xi.tail<3>() = phi;
  return xi;
}

double rotationAngle(const Eigen::Matrix3d& R) {
  return std::atan2(so3Vee(R).norm(), 0.5 * (R.trace() - 1.0));
}

double rotationAngleBetween(const Eigen::Matrix3d& Ra, const Eigen::Matrix3d& Rb) {
  return rotationAngle(Ra.transpose() * Rb);
}

double rotationAngleBetween(const Eigen::Quaterniond& qa, const Eigen::Quaterniond& qb) {
  const Eigen::Quaterniond d = qa.normalized().conjugate() * qb.normalized();
  // q and -q are the same rotation: the half angle is measured from |w|.
  return 2.0 * std::atan2(d.vec().norm(), std::abs(d.w()));
}

Eigen::Quaterniond slerp(const Eigen::Quaterniond& q0, const Eigen::Quaterniond& q1, double t) {
  if (!std::isfinite(t)) throw InvalidArgumentError("slerp: the interpolation parameter t is not finite");
  const double n0 = q0.norm();
  const double n1 = q1.norm();
  if (!std::isfinite(n0) || !std::isfinite(n1) || n0 == 0.0 || n1 == 0.0) {
    throw InvalidArgumentError("slerp: a quaternion is zero or not finite; pass unit quaternions");
  }
  const Eigen::Quaterniond a(Eigen::Vector4d(q0.coeffs() / n0));
  const Eigen::Quaterniond b(Eigen::Vector4d(q1.coeffs() / n1));
  Eigen::Quaterniond d = a.conjugate() * b;
  if (d.w() < 0.0) d.coeffs() = -d.coeffs();  // shortest arc
  const double vn = d.vec().norm();
  if (vn == 0.0) return a;
  const double half = std::atan2(vn, d.w());
  const double ht = t * half;
  Eigen::Quaterniond step;
  step.w() = std::cos(ht);
  step.vec() = std::sin(ht) * d.vec() / vn;
  return (a * step).normalized();
}

Eigen::Matrix3d slerp(const Eigen::Matrix3d& R0, const Eigen::Matrix3d& R1, double t) {
  if (!std::isfinite(t)) throw InvalidArgumentError("slerp: the interpolation parameter t is not finite");
  return R0 * so3Exp(t * so3Log(R0.transpose() * R1));
}

Eigen::Isometry3d interpolatePose(const Eigen::Isometry3d& a, const Eigen::Isometry3d& b, double t) {
  if (!std::isfinite(t)) throw InvalidArgumentError("interpolatePose: the interpolation parameter t is not finite");
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = slerp(Eigen::Matrix3d(a.linear()), Eigen::Matrix3d(b.linear()), t);
  T.translation() = (1.0 - t) * a.translation() + t * b.translation();
  return T;
}

bool isRigid(const Eigen::Matrix4d& M, double tol) {
  if (!M.allFinite()) return false;
  const Eigen::RowVector4d bottom(0.0, 0.0, 0.0, 1.0);
  if ((M.row(3) - bottom).cwiseAbs().maxCoeff() > tol) return false;
  const Eigen::Matrix3d R = M.topLeftCorner<3, 3>();
  if ((R.transpose() * R - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff() > tol) return false;
  return R.determinant() > 0.0;
}

Eigen::Matrix3d nearestRotation(const Eigen::Matrix3d& A) {
  if (!A.allFinite()) throw InvalidArgumentError("nearestRotation: the matrix contains NaN or infinite values");
  const Eigen::JacobiSVD<Eigen::Matrix3d> svd(A, Eigen::ComputeFullU | Eigen::ComputeFullV);
  const Eigen::Vector3d sv = svd.singularValues();
  if (sv(0) == 0.0 || sv(2) < 1e-9 * sv(0)) {
    throw InvalidArgumentError(
        "nearestRotation: the 3x3 rotation block is singular (a projection or zero matrix), so no rotation is "
        "close to it; check the transform's source");
  }
  if (A.determinant() < 0.0) {
    throw InvalidArgumentError(
        "nearestRotation: the 3x3 rotation block is a reflection (negative determinant), which no rigid transform "
        "represents; check the handedness of the source frame");
  }
  const Eigen::Matrix3d U = svd.matrixU();
  const Eigen::Matrix3d V = svd.matrixV();
  Eigen::Matrix3d D = Eigen::Matrix3d::Identity();
  D(2, 2) = (U * V.transpose()).determinant() < 0.0 ? -1.0 : 1.0;
  return U * D * V.transpose();
}

Eigen::Isometry3d orthonormalize(const Eigen::Matrix4d& M) {
  if (!M.allFinite()) {
    throw InvalidArgumentError("orthonormalize: the matrix " + matrixText(M) + " contains NaN or infinite values");
  }
  const Eigen::RowVector4d bottom(0.0, 0.0, 0.0, 1.0);
  if ((M.row(3) - bottom).cwiseAbs().maxCoeff() > 1e-6) {
    throw InvalidArgumentError("orthonormalize: the bottom row of " + matrixText(M) +
                               " is not [0 0 0 1]; it is not an affine transform (projective or transposed?)");
  }
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = nearestRotation(M.topLeftCorner<3, 3>());
  T.translation() = M.topRightCorner<3, 1>();
  return T;
}

Eigen::Matrix4d matrixFromRowMajor(std::span<const double, 16> values) {
  Eigen::Matrix4d M;
  for (int r = 0; r < 4; ++r) {
    for (int c = 0; c < 4; ++c) {
      const double v = values[static_cast<std::size_t>(4 * r + c)];
      if (!std::isfinite(v)) {
        throw InvalidArgumentError("matrixFromRowMajor: element (" + std::to_string(r) + ", " + std::to_string(c) +
                                   ") is not finite");
      }
      M(r, c) = v;
    }
  }
  return M;
}

Eigen::Isometry3d isometryFromRowMajor(std::span<const double, 16> values, double tol) {
  const Eigen::Matrix4d M = matrixFromRowMajor(values);
  if (!isRigid(M, tol)) {
    throw InvalidArgumentError("isometryFromRowMajor: " + matrixText(M) + " is not a rigid transform within " +
                               std::to_string(tol) +
                               " (rotation block not orthonormal, reflection, or bottom row not [0 0 0 1]); use "
                               "orthonormalize() to accept a slightly non-orthonormal matrix");
  }
  Eigen::Isometry3d T;
  T.matrix() = M;
  T.makeAffine();
  return T;
}

std::array<double, 16> toRowMajor(const Eigen::Isometry3d& T) {
  std::array<double, 16> out{};
  for (int r = 0; r < 4; ++r) {
    for (int c = 0; c < 4; ++c) out[static_cast<std::size_t>(4 * r + c)] = T.matrix()(r, c);
  }
  return out;
}

}  // namespace mrsns
