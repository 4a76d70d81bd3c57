// Property tests of the SO(3)/SE(3) maps in the manner of manif's common tester: every
// property is checked on the identity, a tiny element, elements near and at pi, and seeded
// random elements.
#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <limits>
#include <numbers>
#include <random>
#include <vector>

#include "mrsns/core/error.h"
#include "mrsns/core/rigid.h"
#include "mrsns/core/units.h"

namespace mrsns {
namespace {

Eigen::Vector3d randomUnit(std::mt19937& rng) {
  std::normal_distribution<double> n(0.0, 1.0);
  Eigen::Vector3d v;
  do {
    v = Eigen::Vector3d(n(rng), n(rng), n(rng));
  } while (v.norm() < 1e-3);
  return v.normalized();
}

// Rotation vectors covering the special cases plus random ones with |phi| < pi.
std::vector<Eigen::Vector3d> sampleRotationVectors() {
  std::mt19937 rng(20240611);
  std::uniform_real_distribution<double> angle(0.0, kPi);
  std::vector<Eigen::Vector3d> out = {
      Eigen::Vector3d::Zero(),
      1e-9 * Eigen::Vector3d(1, 2, 3).normalized(),
      1e-5 * Eigen::Vector3d(-1, 0.5, 2).normalized(),  // just below the series threshold
      (kPi - 1e-6) * Eigen::Vector3d(0.3, -0.4, 0.5).normalized(),
      (kPi - 1e-6) * Eigen::Vector3d::UnitZ(),
      (kPi - 1e-3) * Eigen::Vector3d(1, 1, -1).normalized(),
      (kPi - 1e-10) * Eigen::Vector3d(-2, 1, 3).normalized(),
  };
  for (int i = 0; i < 200; ++i) out.push_back(angle(rng) * randomUnit(rng));
  return out;
}

Eigen::Matrix3d randomRotation(std::mt19937& rng) {
  std::uniform_real_distribution<double> angle(0.0, kPi);
  return so3Exp(angle(rng) * randomUnit(rng));
}

// exp of a 4x4 matrix by scaling and squaring of a Taylor series: an independent reference.
Eigen::Matrix4d referenceExpm(const Eigen::Matrix4d& X) {
  const int squarings = 12;
  const Eigen::Matrix4d A = X / std::pow(2.0, squarings);
  Eigen::Matrix4d term = Eigen::Matrix4d::Identity();
  Eigen::Matrix4d sum = Eigen::Matrix4d::Identity();
  for (int k = 1; k < 20; ++k) {
    term = term * A / static_cast<double>(k);
    sum += term;
  }
  for (int i = 0; i < squarings; ++i) sum = sum * sum;
  return sum;
}

TEST(Rigid, HatVeeAreInverseAndHatIsTheCrossProduct) {
  std::mt19937 rng(1);
  std::normal_distribution<double> n(0.0, 2.0);
  for (int i = 0; i < 50; ++i) {
    const Eigen::Vector3d w(n(rng), n(rng), n(rng));
    const Eigen::Vector3d v(n(rng), n(rng), n(rng));
    EXPECT_TRUE((so3Hat(w) * v).isApprox(w.cross(v), 1e-14));
    EXPECT_TRUE(so3Vee(so3Hat(w)).isApprox(w, 1e-15));
    EXPECT_TRUE((so3Hat(w) + so3Hat(w).transpose()).isZero(0.0));
  }
}

TEST(Rigid, ExpGivesProperRotationWithAngleNorm) {
  for (const Eigen::Vector3d& phi : sampleRotationVectors()) {
    const Eigen::Matrix3d R = so3Exp(phi);
    EXPECT_LT((R.transpose() * R - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff(), 1e-14);
    EXPECT_NEAR(R.determinant(), 1.0, 1e-14);
    EXPECT_NEAR(rotationAngle(R), phi.norm(), 1e-12) << phi.transpose();
    // The axis is a fixed point of the rotation.
    EXPECT_LT((R * phi - phi).norm(), 1e-14 * (1.0 + phi.norm()));
  }
}

TEST(Rigid, LogOfExpIsIdentityBelowPi) {
  // A log that takes the axis from sin(theta) near pi loses ~eps / (pi - theta) here (1e-10 at
  // pi - 1e-6); the symmetric-part axis keeps full precision.
  for (const Eigen::Vector3d& phi : sampleRotationVectors()) {
    EXPECT_LT((so3Log(so3Exp(phi)) - phi).norm(), 1e-13) << phi.transpose();
  }
}

TEST(Rigid, ExpOfLogIsIdentityForRandomRotations) {
  std::mt19937 rng(2);
  for (int i = 0; i < 200; ++i) {
    const Eigen::Matrix3d R = randomRotation(rng);
    EXPECT_LT((so3Exp(so3Log(R)) - R).cwiseAbs().maxCoeff(), 1e-12);
    EXPECT_LE(so3Log(R).norm(), kPi);
  }
}

TEST(Rigid, TinyAnglesKeepRelativePrecision) {
  // An absolute tolerance would pass a log that returned zero; these angles are far below
  // sqrt(eps) where naive acos-based logs lose all digits.
  for (double angle : {1e-9, 1e-12, 1e-15}) {
    const Eigen::Vector3d phi = angle * Eigen::Vector3d(2, -1, 0.5).normalized();
    const Eigen::Vector3d back = so3Log(so3Exp(phi));
    EXPECT_LT((back - phi).norm() / angle, 1e-12) << angle;
    EXPECT_NEAR(rotationAngle(so3Exp(phi)) / angle, 1.0, 1e-12);
  }
}

TEST(Rigid, LogOfRotationByExactlyPi) {
  const std::array<Eigen::Matrix3d, 3> half_turns = {
      Eigen::Vector3d(1, -1, -1).asDiagonal().toDenseMatrix(),
      Eigen::Vector3d(-1, 1, -1).asDiagonal().toDenseMatrix(),
      Eigen::Vector3d(-1, -1, 1).asDiagonal().toDenseMatrix(),
  };
  for (std::size_t axis = 0; axis < 3; ++axis) {
    const Eigen::Vector3d phi = so3Log(half_turns[axis]);
    ASSERT_TRUE(phi.allFinite());
    EXPECT_NEAR(phi.norm(), kPi, 1e-15);
    EXPECT_NEAR(std::abs(phi(static_cast<Eigen::Index>(axis))), kPi, 1e-15);
    EXPECT_LT((so3Exp(phi) - half_turns[axis]).cwiseAbs().maxCoeff(), 1e-15);
  }
  // A half turn about an oblique axis, built exactly as 2 k k^T - I.
  const Eigen::Vector3d k = Eigen::Vector3d(1, 2, 2) / 3.0;
  const Eigen::Matrix3d R = 2.0 * k * k.transpose() - Eigen::Matrix3d::Identity();
  const Eigen::Vector3d phi = so3Log(R);
  EXPECT_NEAR(phi.norm(), kPi, 1e-12);
  EXPECT_NEAR(std::abs(phi.normalized().dot(k)), 1.0, 1e-14);
  EXPECT_LT((so3Exp(phi) - R).cwiseAbs().maxCoeff(), 1e-12);
}

TEST(Rigid, LeftJacobianMatchesFiniteDifferenceAndHasInverse) {
  std::mt19937 rng(3);
  for (const Eigen::Vector3d& phi : sampleRotationVectors()) {
    const Eigen::Matrix3d J = so3LeftJacobian(phi);
    EXPECT_LT((J * so3LeftJacobianInverse(phi) - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff(), 1e-9)
        << phi.transpose();
    if (phi.norm() > kPi - 1e-2) continue;  // the log wraps near pi; the difference is meaningless there
    // Exp(phi + d) = Exp(J_l(phi) d) Exp(phi) + O(|d|^2).
    const Eigen::Vector3d d = 1e-6 * randomUnit(rng);
    const Eigen::Vector3d lhs = so3Log(so3Exp(phi + d) * so3Exp(phi).transpose());
    EXPECT_LT((lhs - J * d).norm(), 1e-11) << phi.transpose();
  }
}

TEST(Rigid, Se3ExpMatchesMatrixExponentialAndRoundTrips) {
  std::mt19937 rng(4);
  std::normal_distribution<double> n(0.0, 50.0);  // mm
  for (const Eigen::Vector3d& phi : sampleRotationVectors()) {
    Vector6d xi;
    xi << n(rng), n(rng), n(rng), phi;
    const Eigen::Isometry3d T = se3Exp(xi);
    const double scale = 1.0 + xi.head<3>().norm();
    EXPECT_LT((T.matrix() - referenceExpm(se3Hat(xi))).cwiseAbs().maxCoeff(), 1e-10 * scale) << xi.transpose();
    EXPECT_LT((se3Log(T) - xi).norm(), 1e-9 * scale) << xi.transpose();
    EXPECT_LT((se3Exp(se3Log(T)).matrix() - T.matrix()).cwiseAbs().maxCoeff(), 1e-12 * scale);
  }
  Vector6d pure_translation;
  pure_translation << 1.0, -2.0, 3.0, 0.0, 0.0, 0.0;
  EXPECT_TRUE(se3Exp(pure_translation).translation().isApprox(Eigen::Vector3d(1.0, -2.0, 3.0), 1e-15));
}

TEST(Rigid, RotationAngleBetweenIsTheGeodesicDistance) {
  std::mt19937 rng(5);
  for (double angle : {0.0, 1e-9, 0.3, 2.0, kPi - 1e-6, kPi}) {
    const Eigen::Matrix3d Ra = randomRotation(rng);
    const Eigen::Vector3d axis = randomUnit(rng);
    const Eigen::Matrix3d Rb = Ra * so3Exp(angle * axis);
    EXPECT_NEAR(rotationAngleBetween(Ra, Rb), angle, 1e-12) << angle;
    EXPECT_NEAR(rotationAngleBetween(Rb, Ra), angle, 1e-12) << angle;
    const Eigen::Quaterniond qa(Ra);
    Eigen::Quaterniond qb(Rb);
    qb.coeffs() = -qb.coeffs();  // the other sign of the same rotation
    EXPECT_NEAR(rotationAngleBetween(qa, qb), angle, 1e-9) << angle;
  }
}

TEST(Rigid, SlerpHitsEndpointsAtConstantAngularSpeed) {
  std::mt19937 rng(6);
  for (int i = 0; i < 50; ++i) {
    const Eigen::Quaterniond q0(randomRotation(rng));
    const Eigen::Quaterniond q1(randomRotation(rng));
    const double total = rotationAngleBetween(q0, q1);
    EXPECT_NEAR(rotationAngleBetween(slerp(q0, q1, 0.0), q0), 0.0, 1e-12);
    EXPECT_NEAR(rotationAngleBetween(slerp(q0, q1, 1.0), q1), 0.0, 1e-12);
    for (double t : {0.1, 0.25, 0.5, 0.9}) {
      const Eigen::Quaterniond qt = slerp(q0, q1, t);
      EXPECT_NEAR(qt.norm(), 1.0, 1e-15);
      EXPECT_NEAR(rotationAngleBetween(q0, qt), t * total, 1e-12);
      EXPECT_NEAR(rotationAngleBetween(qt, q1), (1.0 - t) * total, 1e-12);
    }
    // q1 and -q1 are the same rotation: slerp takes the short arc either way.
    Eigen::Quaterniond q1_neg = q1;
    q1_neg.coeffs() = -q1.coeffs();
    EXPECT_NEAR(rotationAngleBetween(slerp(q0, q1, 0.3), slerp(q0, q1_neg, 0.3)), 0.0, 1e-12);
    // The matrix form agrees with the quaternion form.
    const Eigen::Matrix3d Rt = slerp(q0.toRotationMatrix(), q1.toRotationMatrix(), 0.3);
    EXPECT_LT((Rt - slerp(q0, q1, 0.3).toRotationMatrix()).cwiseAbs().maxCoeff(), 1e-12);
  }
}

TEST(Rigid, SlerpRejectsNanAndZeroQuaternions) {
  const Eigen::Quaterniond q = Eigen::Quaterniond::Identity();
  EXPECT_THROW(slerp(q, q, std::numeric_limits<double>::quiet_NaN()), InvalidArgumentError);
  EXPECT_THROW(slerp(q, Eigen::Quaterniond(0, 0, 0, 0), 0.5), InvalidArgumentError);
  EXPECT_THROW(interpolatePose(Eigen::Isometry3d::Identity(), Eigen::Isometry3d::Identity(),
                               std::numeric_limits<double>::quiet_NaN()),
               InvalidArgumentError);
}

TEST(Rigid, InterpolatePoseSlerpsRotationAndLerpsTranslation) {
  std::mt19937 rng(7);
  Eigen::Isometry3d a = Eigen::Isometry3d::Identity();
  a.linear() = randomRotation(rng);
  a.translation() = Eigen::Vector3d(10, 20, 30);
  Eigen::Isometry3d b = Eigen::Isometry3d::Identity();
  b.linear() = a.linear() * so3Exp(Eigen::Vector3d(0.0, 0.0, 1.2));
  b.translation() = Eigen::Vector3d(-10, 0, 50);
  EXPECT_TRUE(interpolatePose(a, b, 0.0).isApprox(a, 1e-14));
  EXPECT_TRUE(interpolatePose(a, b, 1.0).isApprox(b, 1e-14));
  const Eigen::Isometry3d mid = interpolatePose(a, b, 0.25);
  EXPECT_TRUE(mid.translation().isApprox(Eigen::Vector3d(5, 15, 35), 1e-14));
  EXPECT_NEAR(rotationAngleBetween(a.linear(), mid.linear()), 0.3, 1e-14);
  EXPECT_TRUE(mid.linear().isApprox(a.linear() * so3Exp(Eigen::Vector3d(0.0, 0.0, 0.3)), 1e-14));
}

TEST(Rigid, IsRigidAndOrthonormalizeRepairPrintedMatrices) {
  std::mt19937 rng(8);
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = randomRotation(rng);
  T.translation() = Eigen::Vector3d(1, 2, 3);
  EXPECT_TRUE(isRigid(T.matrix(), 1e-12));

  // A matrix printed with 4 decimals is off by up to 5e-5 per element.
  Eigen::Matrix4d printed = T.matrix();
  printed.topLeftCorner<3, 3>() = (printed.topLeftCorner<3, 3>() * 1e4).array().round() / 1e4;
  EXPECT_FALSE(isRigid(printed, 1e-8));
  EXPECT_TRUE(isRigid(printed, 1e-3));
  const Eigen::Isometry3d repaired = orthonormalize(printed);
  EXPECT_TRUE(isRigid(repaired.matrix(), 1e-14));
  EXPECT_LT(rotationAngleBetween(repaired.linear(), T.linear()), 3 * 5e-5);
  EXPECT_TRUE(repaired.translation().isApprox(T.translation()));

  Eigen::Matrix4d reflection = T.matrix();
  reflection.col(0) *= -1.0;
  EXPECT_FALSE(isRigid(reflection, 1e-6));
  EXPECT_THROW(orthonormalize(reflection), InvalidArgumentError);

  Eigen::Matrix4d singular = Eigen::Matrix4d::Identity();
  singular(2, 2) = 0.0;
  EXPECT_THROW(orthonormalize(singular), InvalidArgumentError);

  Eigen::Matrix4d projective = T.matrix();
  projective(3, 0) = 0.1;
  EXPECT_FALSE(isRigid(projective, 1e-6));
  EXPECT_THROW(orthonormalize(projective), InvalidArgumentError);

  Eigen::Matrix4d nan = T.matrix();
  nan(1, 1) = std::numeric_limits<double>::quiet_NaN();
  EXPECT_FALSE(isRigid(nan, 1e-6));
  EXPECT_THROW(orthonormalize(nan), InvalidArgumentError);
}

TEST(Rigid, RowMajorArraysRoundTrip) {
  std::mt19937 rng(9);
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = randomRotation(rng);
  T.translation() = Eigen::Vector3d(-4, 5, 6);
  const std::array<double, 16> values = toRowMajor(T);
  EXPECT_EQ(values[3], -4.0);  // row 0, column 3: the x translation
  EXPECT_EQ(values[7], 5.0);
  EXPECT_EQ(values[15], 1.0);
  EXPECT_TRUE(isometryFromRowMajor(values).isApprox(T, 0.0));

  std::array<double, 16> bad = values;
  bad[5] = std::numeric_limits<double>::infinity();
  EXPECT_THROW(matrixFromRowMajor(bad), InvalidArgumentError);
  bad = values;
  bad[0] *= 1.01;  // stretched, not rigid
  EXPECT_THROW(isometryFromRowMajor(bad), InvalidArgumentError);
  EXPECT_NO_THROW(orthonormalize(matrixFromRowMajor(bad)));
}

}  // namespace
}  // namespace mrsns
