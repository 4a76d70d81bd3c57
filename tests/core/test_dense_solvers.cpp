// Property tests of the dense solvers the libraries share (core/dense_solvers.h):
// factorisations that reproduce their input, orthonormal factors, descending
// singular values, least-squares solutions that satisfy the normal equations,
// and the minimum-norm solution of a rank-deficient system. Shapes cover the
// callers': tall shape-model data matrices, square Jacobians, the 8n x 8
// dual-quaternion system of hand-eye calibration.
#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <random>
#include <utility>
#include <vector>

#include "mrsns/core/dense_solvers.h"

namespace mrsns {
namespace {

Eigen::MatrixXd randomMatrix(Eigen::Index rows, Eigen::Index cols, std::mt19937& rng) {
  std::normal_distribution<double> n(0.0, 1.0);
  Eigen::MatrixXd a(rows, cols);
  for (Eigen::Index i = 0; i < a.size(); ++i) a.data()[i] = n(rng);
  return a;
}

const std::vector<std::pair<Eigen::Index, Eigen::Index>> kShapes = {{300, 12}, {6, 6}, {16, 8}, {5, 9}, {1, 4}, {40, 1}};

TEST(DenseSolvers, ThinSvdReproducesTheMatrixWithOrthonormalFactors) {
  std::mt19937 rng(7);
  for (const auto& [rows, cols] : kShapes) {
    const Eigen::MatrixXd a = randomMatrix(rows, cols, rng);
    const ThinSvd svd = thinSvd(a, SvdVectors::kUV);
    const Eigen::Index k = std::min(rows, cols);
    ASSERT_EQ(svd.u.rows(), rows);
    ASSERT_EQ(svd.u.cols(), k);
    ASSERT_EQ(svd.v.rows(), cols);
    ASSERT_EQ(svd.v.cols(), k);
    ASSERT_EQ(svd.singular_values.size(), k);
    const double scale = a.norm();
    EXPECT_LT((svd.u * svd.singular_values.asDiagonal() * svd.v.transpose() - a).norm(), 1e-12 * scale)
        << rows << "x" << cols;
    EXPECT_LT((svd.u.transpose() * svd.u - Eigen::MatrixXd::Identity(k, k)).norm(), 1e-12);
    EXPECT_LT((svd.v.transpose() * svd.v - Eigen::MatrixXd::Identity(k, k)).norm(), 1e-12);
    for (Eigen::Index i = 0; i < k; ++i) {
      EXPECT_GE(svd.singular_values[i], 0.0);
      if (i > 0) {
        EXPECT_LE(svd.singular_values[i], svd.singular_values[i - 1]);
      }
    }
    // The singular values are those of the full decomposition (Frobenius norm).
    EXPECT_NEAR(svd.singular_values.norm(), scale, 1e-12 * scale);
  }
}

TEST(DenseSolvers, ThinSvdComputesOnlyTheVectorsAskedFor) {
  std::mt19937 rng(8);
  const Eigen::MatrixXd a = randomMatrix(20, 4, rng);
  const ThinSvd none = thinSvd(a, SvdVectors::kNone);
  EXPECT_EQ(none.u.size(), 0);
  EXPECT_EQ(none.v.size(), 0);
  const ThinSvd u = thinSvd(a, SvdVectors::kU);
  EXPECT_EQ(u.u.rows(), 20);
  EXPECT_EQ(u.v.size(), 0);
  const ThinSvd v = thinSvd(a, SvdVectors::kV);
  EXPECT_EQ(v.u.size(), 0);
  EXPECT_EQ(v.v.rows(), 4);
  EXPECT_LT((none.singular_values - u.singular_values).norm(), 1e-12);
  EXPECT_LT((none.singular_values - v.singular_values).norm(), 1e-12);
}

TEST(DenseSolvers, ALowRankMatrixHasZeroTrailingSingularValues) {
  std::mt19937 rng(9);
  // Rank 3 in 50 x 10: what a shape model's data matrix of 4 centred examples is.
  const Eigen::MatrixXd a = randomMatrix(50, 3, rng) * randomMatrix(3, 10, rng);
  const ThinSvd svd = thinSvd(a, SvdVectors::kU);
  EXPECT_GT(svd.singular_values[2], 1e-3 * svd.singular_values[0]);
  for (Eigen::Index i = 3; i < 10; ++i) EXPECT_LT(svd.singular_values[i], 1e-12 * svd.singular_values[0]);
  // The first three left singular vectors span the column space.
  const Eigen::MatrixXd u3 = svd.u.leftCols(3);
  EXPECT_LT((u3 * (u3.transpose() * a) - a).norm(), 1e-10 * a.norm());
}

TEST(DenseSolvers, LeastSquaresSatisfiesTheNormalEquations) {
  std::mt19937 rng(10);
  for (const auto& [rows, cols] : std::vector<std::pair<Eigen::Index, Eigen::Index>>{{60, 6}, {12, 12}, {9, 3}}) {
    const Eigen::MatrixXd a = randomMatrix(rows, cols, rng);
    const Eigen::VectorXd b = randomMatrix(rows, 1, rng);
    Eigen::VectorXd singular_values;
    const Eigen::VectorXd x_svd = svdLeastSquares(a, b, &singular_values);
    const Eigen::VectorXd x_qr = qrLeastSquares(a, b);
    // A^T (A x - b) = 0 at the least-squares solution.
    EXPECT_LT((a.transpose() * (a * x_svd - b)).norm(), 1e-10 * a.norm() * b.norm());
    EXPECT_LT((a.transpose() * (a * x_qr - b)).norm(), 1e-10 * a.norm() * b.norm());
    EXPECT_LT((x_svd - x_qr).norm(), 1e-9 * (1.0 + x_svd.norm()));
    ASSERT_EQ(singular_values.size(), cols);
    EXPECT_LT((singular_values - thinSvd(a, SvdVectors::kNone).singular_values).norm(), 1e-12 * a.norm());
  }
}

TEST(DenseSolvers, ARankDeficientSystemGetsTheMinimumNormSolution) {
  // Columns 0 and 1 identical: x0 + x1 is determined, x0 - x1 is not; the
  // minimum-norm solution splits the sum evenly.
  Eigen::MatrixXd a(4, 2);
  a << 1, 1, 2, 2, 3, 3, 4, 4;
  const Eigen::VectorXd b = a.col(0) * 3.0;
  Eigen::VectorXd singular_values;
  const Eigen::VectorXd x = svdLeastSquares(a, b, &singular_values);
  EXPECT_NEAR(x[0], 1.5, 1e-12);
  EXPECT_NEAR(x[1], 1.5, 1e-12);
  EXPECT_LT(singular_values[1], 1e-12 * singular_values[0]);
}

}  // namespace
}  // namespace mrsns
