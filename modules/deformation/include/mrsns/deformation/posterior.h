#pragma once
// The posterior shape model (paper 001 Eq. 7, 9-11; Albrecht et al. 2013):
// given observations of a few model points, the distribution of the full
// shape, computed with the n x n system of the model's modes only.

#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <span>
#include <vector>

#include "mrsns/core/shape_model.h"

namespace mrsns::deformation {

/// A point of the model surface, as a fixed weighted combination of up to 4
/// vertices (a vertex, a point on an edge, in a face, or between two edge
/// points of a plane cut), observed at `point` (model frame, mm).
struct ModelPointObservation {
  std::array<std::int32_t, 4> vertices{-1, -1, -1, -1};  ///< -1 = unused slot.
  Eigen::Vector4d weights = Eigen::Vector4d::Zero();
  Eigen::Vector3d point = Eigen::Vector3d::Zero();

  /// Observation of vertex `v` at `p`.
  static ModelPointObservation atVertex(std::int32_t v, const Eigen::Vector3d& p) {
    ModelPointObservation o;
    o.vertices[0] = v;
    o.weights[0] = 1.0;
    o.point = p;
    return o;
  }
};

struct PosteriorOptions {
  /// Standard deviation of the isotropic observation noise (sigma of Eq. 7, mm).
  double noise_sigma_mm = 1.0;
  /// An observation is implausible when its residual to the posterior,
  /// standardised by the posterior predictive covariance (3 dof Mahalanobis),
  /// exceeds this; such observations are excluded and the posterior recomputed.
  double outlier_mahalanobis = 4.0;
  int max_outlier_rounds = 3;
  /// The posterior shape is flagged implausible when |alpha|^2 exceeds the
  /// chi-square(n) mean plus this many standard deviations: n + k sqrt(2n).
  double implausible_sigmas = 4.0;
  /// Fill PosteriorResult::vertex_covariances (N 3x3 blocks of Eq. 11).
  bool compute_vertex_covariances = false;
};

struct PosteriorResult {
  /// Posterior mean shape (Eq. 10), 3N.
  Eigen::VectorXd mean;
  /// Posterior mean coefficients alpha (standard-normal model coordinates).
  Eigen::VectorXd coefficients;
  /// Posterior covariance of alpha: sigma^2 (Qp^T Qp + sigma^2 I)^-1 (n x n);
  /// Eq. 11 is Q * this * Q^T.
  Eigen::MatrixXd coefficient_covariance;
  /// Per-vertex 3x3 blocks of Eq. 11 when requested (mm^2).
  std::vector<Eigen::Matrix3d> vertex_covariances;
  /// |alpha|: Mahalanobis distance of the posterior mean from the prior mean.
  double mahalanobis = 0.0;
  /// False when the Mahalanobis distance is beyond PosteriorOptions::implausible_sigmas.
  bool plausible = true;
  /// Per observation: distance (mm) between the observed point and the posterior.
  Eigen::VectorXd residuals_mm;
  /// Per observation: standardised (Mahalanobis) residual against the posterior predictive.
  Eigen::VectorXd residual_mahalanobis;
  /// Indices of observations flagged implausible and left out.
  std::vector<int> excluded;
  int used_observations = 0;
  double rms_residual_mm = 0.0;  ///< Over the used observations.
};

/// The normal equations of Eq. 10 kept up to date while observations are
/// added and replaced one at a time (V^p of Algorithm 1), so a frame costs
/// O(changed observations x n^2) to update and O(k n^2) to solve, never
/// O(N n): Qp^T Qp and Qp^T (x_p - mu_p) are adjusted by each change, and
/// every `rebuild_interval` changes recomputed from the kept rows so
/// round-off cannot accumulate.
class PosteriorNormalEquations {
 public:
  explicit PosteriorNormalEquations(Eigen::Index modes, int rebuild_interval = 1024);

  /// Appends an observation (rows and prior mean taken from `model`).
  void add(const ShapeModel& model, const ModelPointObservation& observation);
  /// Replaces observation `index` (0 <= index < size()).
  void replace(std::size_t index, const ShapeModel& model, const ModelPointObservation& observation);
  void clear();
  [[nodiscard]] std::size_t size() const { return static_cast<std::size_t>(count_); }
  [[nodiscard]] Eigen::Index modes() const { return qtq_.rows(); }

  /// The posterior of computePosterior (outlier rounds included) except the
  /// mean shape, left empty: evaluate only the vertices needed from the
  /// coefficients (modelInstance gives the whole shape). Throws ComputationError when the
  /// system is not positive definite, InvalidArgumentError for a bad sigma.
  [[nodiscard]] PosteriorResult solve(const PosteriorOptions& options) const;

 private:
  void rebuild();

  Eigen::Index count_ = 0;
  Eigen::MatrixXd rows_;         // 3 x n block per observation, stacked (3 * capacity x n)
  Eigen::VectorXd residuals_;    // observed point - prior mean at it, stacked
  Eigen::MatrixXd qtq_;          // sum of rows^T rows
  Eigen::VectorXd qtd_;          // sum of rows^T residual
  int changes_since_rebuild_ = 0;
  int rebuild_interval_ = 1024;
};

/// The posterior of `model` given `observations`. With none it is the prior
/// (mean, identity coefficient covariance). Throws InvalidArgumentError for a
/// non-positive sigma, vertex indices out of range or non-finite points.
[[nodiscard]] PosteriorResult computePosterior(const ShapeModel& model,
                                               std::span<const ModelPointObservation> observations,
                                               const PosteriorOptions& options = {});

/// The 3x3 block of Eq. 11 at `vertex`: Q_v * coefficient_covariance * Q_v^T (mm^2).
[[nodiscard]] Eigen::Matrix3d posteriorVertexCovariance(const ShapeModel& model, const PosteriorResult& posterior,
                                                        Eigen::Index vertex);

/// The rows of Q = U diag(sqrt(variances)) for an observation (3 x n).
[[nodiscard]] Eigen::Matrix<double, 3, Eigen::Dynamic> observationRows(const ShapeModel& model,
                                                                       const ModelPointObservation& observation);
/// The prior mean at an observation's model point.
[[nodiscard]] Eigen::Vector3d observationMean(const ShapeModel& model, const ModelPointObservation& observation);

}  // namespace mrsns::deformation
