#pragma once
// A linear (PCA / low-rank Gaussian process) statistical shape model as plain
// data, so that io can read and write it and deformation can compute with it.

#include <Eigen/Core>

#include "mrsns/core/mesh.h"

namespace mrsns {

/// Shapes s = mean + basis * diag(sqrt(variances)) * alpha (+ noise), alpha ~ N(0, I).
/// A shape vector holds the vertices of `reference` in correspondence, interleaved
/// x0 y0 z0 x1 y1 z1 ... (mm, in reference.frame). This is statismo's layout
/// (format 0.9: orthonormal basis, variances separate).
struct ShapeModel {
  /// Topology (faces) of every shape and the reference the model was built on.
  TriangleMesh reference;
  /// Mean shape, size 3N.
  Eigen::VectorXd mean;
  /// Orthonormal principal directions, 3N x n, columns by decreasing variance.
  Eigen::MatrixXd basis;
  /// Variance (mm^2) along each basis column, size n, non-negative.
  Eigen::VectorXd variances;
  /// Isotropic noise variance of the probabilistic PCA model (mm^2).
  double noise_variance = 0.0;

  [[nodiscard]] Eigen::Index pointCount() const { return mean.size() / 3; }
  [[nodiscard]] Eigen::Index modeCount() const { return basis.cols(); }
};

}  // namespace mrsns
