#pragma once
// Small synthetic models for the deformation tests.
#include <Eigen/Core>
#include <Eigen/QR>
#include <random>

#include "mrsns/core/shape_model.h"

namespace mrsns::deformation::testing {

/// A strip of triangles over `points` random vertices (topology only matters for validation).
inline TriangleMesh stripMesh(Eigen::Index points, std::mt19937_64& rng, double extent = 20.0) {
  std::uniform_real_distribution<double> u(-extent, extent);
  TriangleMesh m;
  m.vertices.resize(points, 3);
  for (Eigen::Index i = 0; i < points; ++i) m.vertices.row(i) << u(rng), u(rng), u(rng);
  m.faces.resize(points - 2, 3);
  for (Eigen::Index i = 0; i + 2 < points; ++i) {
    m.faces.row(i) << static_cast<int>(i), static_cast<int>(i + 1), static_cast<int>(i + 2);
  }
  return m;
}

/// A model with a random orthonormal basis and the given variances.
inline ShapeModel randomModel(Eigen::Index points, const Eigen::VectorXd& variances, std::mt19937_64& rng,
                              double noise_variance = 0.0) {
  ShapeModel model;
  model.reference = stripMesh(points, rng);
  model.mean.resize(3 * points);
  for (Eigen::Index i = 0; i < points; ++i) model.mean.segment<3>(3 * i) = model.reference.vertices.row(i).transpose();
  std::normal_distribution<double> n(0.0, 1.0);
  Eigen::MatrixXd a(3 * points, variances.size());
  for (Eigen::Index i = 0; i < a.size(); ++i) a.data()[i] = n(rng);
  Eigen::HouseholderQR<Eigen::MatrixXd> qr(a);
  model.basis = qr.householderQ() * Eigen::MatrixXd::Identity(3 * points, variances.size());
  model.variances = variances;
  model.noise_variance = noise_variance;
  return model;
}

}  // namespace mrsns::deformation::testing
