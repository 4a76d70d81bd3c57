// Closed-form AX = XB solvers: Tsai-Lenz, Park-Martin, Daniilidis.
#include <Eigen/Eigenvalues>
#include <Eigen/SVD>
#include <cmath>
#include <vector>

#include "hand_eye_internal.h"
#include "mrsns/core/dense_solvers.h"
#include "mrsns/core/error.h"
#include "mrsns/core/rigid.h"

namespace mrsns::hand_eye_detail {
namespace {

// Tsai's modified Rodrigues vector 2 sin(theta/2) * axis: bounded, and well defined at pi.
Eigen::Vector3d modifiedRodrigues(const Eigen::Matrix3d& R) {
  const Eigen::Vector3d phi = so3Log(R);
  const double angle = phi.norm();
  if (angle < 1e-15) return Eigen::Vector3d::Zero();
  return 2.0 * std::sin(angle / 2.0) * phi / angle;
}

// Quaternion product matrices: q * p = left(q) p = right(p) q, coefficients (w, x, y, z).
Eigen::Matrix4d leftMatrix(const Eigen::Vector4d& q) {
  Eigen::Matrix4d m;
  m << q(0), -q(1), -q(2), -q(3),  //
      q(1), q(0), -q(3), q(2),     //
      q(2), q(3), q(0), -q(1),     //
      q(3), -q(2), q(1), q(0);
  return m;
}

Eigen::Matrix4d rightMatrix(const Eigen::Vector4d& q) {
  Eigen::Matrix4d m;
  m << q(0), -q(1), -q(2), -q(3),  //
      q(1), q(0), q(3), -q(2),     //
      q(2), -q(3), q(0), q(1),     //
      q(3), q(2), -q(1), q(0);
  return m;
}

struct DualQuaternion {
  Eigen::Vector4d real, dual;  // (w, x, y, z)
};

DualQuaternion toDual(const Eigen::Isometry3d& T) {
  const Eigen::Quaterniond q(T.linear());
  DualQuaternion d;
  d.real = Eigen::Vector4d(q.w(), q.x(), q.y(), q.z());
  const Eigen::Vector3d t = T.translation();
  d.dual = 0.5 * leftMatrix(Eigen::Vector4d(0, t.x(), t.y(), t.z())) * d.real;
  return d;
}

}  // namespace

Eigen::Vector3d translationLeastSquares(const Poses& A, const Poses& B, const Eigen::Matrix3d& R) {
  const auto n = static_cast<Eigen::Index>(A.size());
  Eigen::MatrixXd C(3 * n, 3);
  Eigen::VectorXd d(3 * n);
  for (Eigen::Index i = 0; i < n; ++i) {
    const auto& a = A[static_cast<size_t>(i)];
    const auto& b = B[static_cast<size_t>(i)];
    C.middleRows<3>(3 * i) = a.linear() - Eigen::Matrix3d::Identity();
    d.segment<3>(3 * i) = R * b.translation() - a.translation();
  }
  return qrLeastSquares(C, d);
}

Eigen::Isometry3d solveTsaiLenz(const Poses& A, const Poses& B) {
  const auto n = static_cast<Eigen::Index>(A.size());
  Eigen::MatrixXd C(3 * n, 3);
  Eigen::VectorXd d(3 * n);
  for (Eigen::Index i = 0; i < n; ++i) {
    const Eigen::Vector3d pa = modifiedRodrigues(A[static_cast<size_t>(i)].linear());
    const Eigen::Vector3d pb = modifiedRodrigues(B[static_cast<size_t>(i)].linear());
    C.middleRows<3>(3 * i) = so3Hat(pa + pb);
    d.segment<3>(3 * i) = pb - pa;
  }
  // p' = tan(theta_X / 2) * axis_X; then back to the modified Rodrigues vector of X.
  const Eigen::Vector3d p_prime = qrLeastSquares(C, d);
  const Eigen::Vector3d p = 2.0 * p_prime / std::sqrt(1.0 + p_prime.squaredNorm());
  const double p2 = p.squaredNorm();
  const Eigen::Matrix3d R_raw = (1.0 - p2 / 2.0) * Eigen::Matrix3d::Identity() +
                                0.5 * (p * p.transpose() + std::sqrt(std::max(0.0, 4.0 - p2)) * so3Hat(p));
  Eigen::Isometry3d X = Eigen::Isometry3d::Identity();
  X.linear() = nearestRotation(R_raw);
  X.translation() = translationLeastSquares(A, B, X.linear());
  return X;
}

Eigen::Isometry3d solveParkMartin(const Poses& A, const Poses& B) {
  // alpha_i = R_X beta_i: the rotation closest to mapping all beta onto alpha (orthogonal
  // Procrustes by SVD; equals (M^T M)^-1/2 M^T of the paper when M has full rank).
  Eigen::Matrix3d M = Eigen::Matrix3d::Zero();
  for (size_t i = 0; i < A.size(); ++i) M += so3Log(A[i].linear()) * so3Log(B[i].linear()).transpose();
  Eigen::JacobiSVD<Eigen::Matrix3d> svd(M, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Matrix3d D = Eigen::Matrix3d::Identity();
  if ((svd.matrixU() * svd.matrixV().transpose()).determinant() < 0) D(2, 2) = -1.0;
  Eigen::Isometry3d X = Eigen::Isometry3d::Identity();
  X.linear() = svd.matrixU() * D * svd.matrixV().transpose();
  X.translation() = translationLeastSquares(A, B, X.linear());
  return X;
}

Eigen::Isometry3d solveDaniilidis(const Poses& A, const Poses& B, const Eigen::Matrix3d& rotation_hint) {
  const auto n = static_cast<Eigen::Index>(A.size());
  Eigen::MatrixXd S = Eigen::MatrixXd::Zero(8 * n, 8);
  const Eigen::Quaterniond q_hint(rotation_hint);
  for (Eigen::Index i = 0; i < n; ++i) {
    const DualQuaternion a = toDual(A[static_cast<size_t>(i)]);
    DualQuaternion b = toDual(B[static_cast<size_t>(i)]);
    // a and b must be the same sign; their scalar parts (cos of the same half angle) say which,
    // unless the motion is near pi, where the hint's rotation of b's axis onto a's decides.
    double sign_score = a.real(0) * b.real(0);
    if (std::abs(a.real(0)) < 0.2) {
      const Eigen::Vector3d bv_rotated = q_hint * Eigen::Vector3d(b.real.tail<3>());
      sign_score = a.real.tail<3>().dot(bv_rotated);
    }
    if (sign_score < 0) {
      b.real = -b.real;
      b.dual = -b.dual;
    }
    // a (x) q = q (x) b for the real and dual parts of q = (q_r, q_d).
    const Eigen::Matrix4d K = leftMatrix(a.real) - rightMatrix(b.real);
    const Eigen::Matrix4d Kd = leftMatrix(a.dual) - rightMatrix(b.dual);
    S.block<4, 4>(8 * i, 0) = K;
    S.block<4, 4>(8 * i + 4, 0) = Kd;
    S.block<4, 4>(8 * i + 4, 4) = K;
  }
  // S has 8n >= 8 rows: its thin V is the full 8 x 8.
  const ThinSvd svd = thinSvd(S, SvdVectors::kV);
  const Eigen::VectorXd v7 = svd.v.col(6);
  const Eigen::VectorXd v8 = svd.v.col(7);
  const Eigen::Vector4d u1 = v7.head<4>(), w1 = v7.tail<4>();
  const Eigen::Vector4d u2 = v8.head<4>(), w2 = v8.tail<4>();
  // q = c v7 + s v8 with q_r . q_d = 0: a homogeneous quadratic form in (c, s), solved through
  // its eigenvectors (no division by a coefficient that noise can make zero); of the two
  // roots, the one with the larger real part is scaled to |q_r| = 1.
  Eigen::Matrix2d Q;
  Q << u1.dot(w1), 0.5 * (u1.dot(w2) + u2.dot(w1)), 0.5 * (u1.dot(w2) + u2.dot(w1)), u2.dot(w2);
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> qeig(Q);
  const double e1 = qeig.eigenvalues()(0), e2 = qeig.eigenvalues()(1);
  const Eigen::Vector2d g1 = qeig.eigenvectors().col(0), g2 = qeig.eigenvectors().col(1);
  std::vector<Eigen::Vector2d> roots;
  if (e1 <= 0.0 && e2 >= 0.0 && e2 - e1 > 0.0) {
    const double c1 = std::sqrt(e2 / (e2 - e1)), c2 = std::sqrt(-e1 / (e2 - e1));
    roots = {c1 * g1 + c2 * g2, c1 * g1 - c2 * g2};
  } else {
    roots = {std::abs(e1) < std::abs(e2) ? g1 : g2};  // noise made Q definite: nearest root
  }
  Eigen::Vector4d qr = Eigen::Vector4d::UnitX(), qd = Eigen::Vector4d::Zero();
  double best = -1.0;
  for (const auto& r : roots) {
    const Eigen::Vector4d real = r(0) * u1 + r(1) * u2;
    if (real.norm() > best) {
      best = real.norm();
      qr = real / best;
      qd = (r(0) * w1 + r(1) * w2) / best;
    }
  }
  Eigen::Isometry3d X = Eigen::Isometry3d::Identity();
  const Eigen::Quaterniond q(qr(0), qr(1), qr(2), qr(3));
  X.linear() = q.normalized().toRotationMatrix();
  // t = 2 q_d (x) conj(q_r)
  const Eigen::Vector4d conj(qr(0), -qr(1), -qr(2), -qr(3));
  const Eigen::Vector4d t = 2.0 * leftMatrix(qd) * conj;
  X.translation() = t.tail<3>();
  return X;
}

double axisSpread(const Poses& motions) {
  Eigen::Matrix3d scatter = Eigen::Matrix3d::Zero();
  for (const auto& m : motions) {
    const Eigen::Vector3d phi = so3Log(m.linear());
    scatter += phi * phi.transpose();
  }
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(scatter);
  const Eigen::Vector3d ev = eig.eigenvalues();  // ascending
  if (ev(2) <= 0.0) return 0.0;
  return std::atan(std::sqrt(std::max(0.0, ev(0) + ev(1)) / ev(2)));
}

}  // namespace mrsns::hand_eye_detail
