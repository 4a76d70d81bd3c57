#include "mrsns/core/dense_solvers.h"

#include <Eigen/QR>
#include <Eigen/SVD>

namespace mrsns {

ThinSvd thinSvd(const Eigen::MatrixXd& a, SvdVectors vectors) {
  unsigned int options = 0;
  if (vectors == SvdVectors::kU || vectors == SvdVectors::kUV) options |= Eigen::ComputeThinU;
  if (vectors == SvdVectors::kV || vectors == SvdVectors::kUV) options |= Eigen::ComputeThinV;
  const Eigen::JacobiSVD<Eigen::MatrixXd> svd(a, options);
  ThinSvd result;
  result.singular_values = svd.singularValues();
  if (svd.computeU()) result.u = svd.matrixU();
  if (svd.computeV()) result.v = svd.matrixV();
  return result;
}

Eigen::VectorXd svdLeastSquares(const Eigen::MatrixXd& a, const Eigen::VectorXd& b, Eigen::VectorXd* singular_values) {
  const Eigen::JacobiSVD<Eigen::MatrixXd> svd(a, Eigen::ComputeThinU | Eigen::ComputeThinV);
  if (singular_values != nullptr) *singular_values = svd.singularValues();
  return svd.solve(b);
}

Eigen::VectorXd qrLeastSquares(const Eigen::MatrixXd& a, const Eigen::VectorXd& b) {
  return a.colPivHouseholderQr().solve(b);
}

}  // namespace mrsns
