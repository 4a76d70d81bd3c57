#pragma once
// The patient's critical soft tissue (the vessel) deforming over time, drawn
// from a statistical shape model: the truth that the posterior shape model of
// the workstation (paper 001, Algorithm 1) has to follow from ultrasound.
//
//   shape(t) = mean + basis * diag(sqrt(variances)) * alpha(t)
//   alpha_i(t) = amplitude_sd * sin(2 pi t / (period_s * f_i) + phi_i)   (i < modes; 0 beyond)
//                + push_sd_i * smoothstep((t - push_start_s) / push_ramp_s)  (a scripted push, held)
//
// f_i in [0.7, 1.3] and phi_i in [0, 2 pi) are drawn from the seed, so the
// truth file can hold the whole trajectory as a few numbers.
#include <Eigen/Core>
#include <memory>
#include <mutex>
#include <string>

#include "mrsns/core/mesh_locator.h"
#include "mrsns/core/shape_model.h"
#include "mrsns/simulation/scenario.h"

namespace mrsns::simulation {

class DeformingSoftTissue {
 public:
  /// Throws InvalidArgumentError for a model without a reference mesh or one
  /// whose sizes disagree, FormatError when `modes` exceeds the model's.
  DeformingSoftTissue(ShapeModel model, const SoftTissueSpec& spec, std::uint64_t seed);

  /// The shape coefficients (standard deviations) at t.
  [[nodiscard]] Eigen::VectorXd coefficients(double t) const;
  /// The surface (model frame) at t, for distance queries; rebuilt at most
  /// every 0.1 s of scenario time (the shape changes over seconds), shared.
  [[nodiscard]] std::shared_ptr<const MeshLocator> surfaceAt(double t) const;
  /// Vertices (model frame, N x 3) at t.
  [[nodiscard]] Eigen::MatrixXd verticesAt(double t) const;
  /// The trajectory's parameters for the truth file (JSON object text).
  [[nodiscard]] std::string truthJson() const;

  [[nodiscard]] const Eigen::Isometry3d& ctTModel() const { return spec_.ct_T_model; }

 private:
  ShapeModel model_;
  SoftTissueSpec spec_;
  Eigen::VectorXd frequency_factor_;
  Eigen::VectorXd phase_;
  mutable std::mutex mutex_;
  mutable long long cached_bucket_ = -1;
  mutable std::shared_ptr<const MeshLocator> cached_;
};

}  // namespace mrsns::simulation
