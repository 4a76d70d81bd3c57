#pragma once
// A carotid-like vessel shape model with one mode that moves the whole vessel sideways (the model's x) by
// `sd_mm` per standard deviation: the simplest soft tissue whose truth is known at every instant (the shift),
// for the simulated room's deforming tissue, the live soft tissue and the scorer. Needs mrsns::deformation.
#include <cmath>

#include "mrsns/core/shape_model.h"
#include "mrsns/deformation/vessel_phantom.h"

namespace mrsns::test {

inline ShapeModel translatingVessel(double sd_mm = 5.0) {
  ShapeModel model;
  model.reference = deformation::makeVesselPhantom(deformation::VesselDeformation{});
  const auto n = model.reference.vertexCount();
  model.mean.resize(3 * n);
  model.basis = Eigen::MatrixXd::Zero(3 * n, 1);
  for (Eigen::Index i = 0; i < n; ++i) {
    model.mean.segment<3>(3 * i) = model.reference.vertices.row(i).transpose();
    model.basis(3 * i, 0) = 1.0 / std::sqrt(static_cast<double>(n));
  }
  // A unit basis vector spread over n vertices moves each by 1/sqrt(n): variance n sd^2 moves each by sd per SD.
  model.variances = Eigen::VectorXd::Constant(1, sd_mm * sd_mm * static_cast<double>(n));
  return model;
}

}  // namespace mrsns::test
