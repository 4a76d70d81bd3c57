#pragma once
// Eigen's dense decompositions of dynamic-size matrices, compiled once.
//
// Each of them is among the costliest templates to compile at -O3: a
// translation unit that instantiates BDCSVD<MatrixXd> spends about a minute
// on it, JacobiSVD<MatrixXd> or ColPivHouseholderQR<MatrixXd> 15-20 s. The
// libraries go through these functions instead of instantiating their own
// copies (fixed-size 3x3 solvers are cheap and stay where they are used).
#include <Eigen/Core>

namespace mrsns {

// Which singular vectors thinSvd computes.
enum class SvdVectors { kNone, kU, kV, kUV };

// a = u diag(singular_values) v^T with k = min(rows, cols): u is rows x k,
// v is cols x k (empty when not asked for), singular values descending and
// >= 0. Two-sided Jacobi after a column-pivoting QR (Eigen's JacobiSVD):
// accurate to the smallest singular values, O(rows cols^2) for tall matrices.
struct ThinSvd {
  Eigen::MatrixXd u;
  Eigen::VectorXd singular_values;
  Eigen::MatrixXd v;
};
ThinSvd thinSvd(const Eigen::MatrixXd& a, SvdVectors vectors);

// The minimum-norm least-squares solution of a x = b through the SVD
// (singular values below Eigen's default threshold treated as zero); the
// singular values of a, when asked for, e.g. for a condition number.
Eigen::VectorXd svdLeastSquares(const Eigen::MatrixXd& a, const Eigen::VectorXd& b,
                                Eigen::VectorXd* singular_values = nullptr);

// The least-squares solution of a x = b by column-pivoting Householder QR:
// faster than the SVD, and rank-revealing.
Eigen::VectorXd qrLeastSquares(const Eigen::MatrixXd& a, const Eigen::VectorXd& b);

}  // namespace mrsns
