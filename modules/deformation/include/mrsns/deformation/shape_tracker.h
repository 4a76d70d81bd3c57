#pragma once
// Paper 001 Algorithm 1: updating a soft-tissue shape from a stream of
// calibrated ultrasound frames. Per frame: the slice plane (image z = 0 mapped
// into the model frame), the contours of the current shape in it, the feature
// contours found in the image, both resampled by Eq. 8 to K points, the
// correspondence update of V^p / V^model with the 1.2 mm threshold, and the
// posterior (Eq. 10-11).

#include <Eigen/Geometry>
#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "mrsns/core/plane_intersection.h"
#include "mrsns/core/shape_model.h"
#include "mrsns/deformation/contour_features.h"
#include "mrsns/deformation/posterior.h"

namespace mrsns::deformation {

/// How the K feature points are paired with the K model-contour points.
enum class ContourCorrespondence {
  /// The paper's step (c)3-4: both contours resampled by Eq. 8 to K points,
  /// paired after the best cyclic shift. Each pair also carries a tangential
  /// offset of up to half a step (the contours start at unrelated angles),
  /// which pulls vertices around the vessel.
  ArcLength,
  /// Each of the K model points (Eq. 8) is observed at its closest point on
  /// the feature contour: only the displacement across the wall, which is
  /// what a cross-section shows.
  ClosestPoint,
};

struct ShapeTrackerOptions {
  ContourCorrespondence correspondence = ContourCorrespondence::ArcLength;
  /// K of Algorithm 1 step (c)3.
  int contour_points = 15;
  /// D^Thr of Algorithm 1 (a)2: a feature point closer than this to a stored
  /// observation replaces it, otherwise it is added (mm).
  double update_threshold_mm = 1.2;
  /// A feature contour is paired with the model contour whose centroid is
  /// nearest, if closer than this (mm); others are ignored.
  double max_centroid_distance_mm = 6.0;
  /// Cut the current posterior (true) or always the prior mean (the paper's
  /// literal step (c)2). The posterior follows the tissue further.
  bool cut_posterior = true;
  /// Per-contour gate: a feature contour whose K paired points, standardised
  /// by the current posterior predictive covariance (Q_v Sigma_alpha Q_v^T +
  /// sigma^2 I, 3 dof each), have an RMS Mahalanobis distance beyond this is
  /// not used (a wrong lumen or a failed fit would pull the whole shape).
  /// The expected RMS for a consistent contour is sqrt(3) = 1.73. 0 = off.
  double contour_gate_mahalanobis = 0.0;
  /// Undo a frame whose observations make the posterior implausible
  /// (PosteriorResult::plausible false): the shape keeps the last plausible
  /// state. Off by default: with exact contours of a shape outside the
  /// model's span (deform-track with an external segmenter) it throws away
  /// good frames; the trial turns it on for its built-in segmenter.
  bool reject_implausible_frames = false;
  /// Observations not renewed (added or replaced) in this many frames are forgotten (frames that cut the
  /// model and bring feature contours: a frame without any does not age them); 0 keeps them all
  /// (the paper's Algorithm 1). Tissue that moves while it is imaged needs it: a wall that moved further
  /// than D^Thr adds new observations beside the old ones instead of replacing them, and the posterior
  /// then averages where the tissue is with where it was.
  int max_observation_age_frames = 0;
  PosteriorOptions posterior;
};

/// What one frame did; real-time use never throws, it reports here.
struct FrameUpdate {
  bool updated = false;  ///< The posterior was recomputed.
  std::string status;    ///< "ok", or why nothing was updated.
  int model_contours = 0;
  int matched_contours = 0;
  int gated_contours = 0;  ///< Matched but refused by the per-contour gate.
  int added = 0;
  int replaced = 0;
  int observations = 0;  ///< Size of V^p after the frame.
  int forgotten = 0;     ///< Observations older than max_observation_age_frames dropped before the frame.
  int excluded = 0;      ///< Observations flagged implausible by the posterior.
  double mahalanobis = 0.0;
  bool plausible = true;
  double elapsed_ms = 0.0;  ///< Intersection + correspondence + posterior mean.
};

class PosteriorShapeTracker {
 public:
  /// Throws InvalidArgumentError for an invalid model or options.
  explicit PosteriorShapeTracker(ShapeModel model, const ShapeTrackerOptions& options = {});

  /// Contours of the current shape in the image plane, in image coordinates
  /// (mm, z = 0): the seed and shape prior of a segmenter.
  [[nodiscard]] std::vector<Polyline3d> predictedContours(const Eigen::Isometry3d& model_T_image) const;

  /// One frame: `feature_contours` are closed contours in image coordinates
  /// (mm, z = 0) from any segmenter. An empty list leaves the shape as it is.
  FrameUpdate update(const Eigen::Isometry3d& model_T_image, std::span<const Polyline3d> feature_contours);

  /// Back to the prior, forgetting every observation.
  void reset();

  [[nodiscard]] const ShapeModel& model() const { return model_; }
  /// The posterior mean shape (3N). A frame does not evaluate it (only the
  /// vertices near the image plane): it is computed here on first use.
  [[nodiscard]] const Eigen::VectorXd& currentShape() const;
  [[nodiscard]] TriangleMesh currentMesh() const;
  /// The posterior, its mean shape included (evaluated on first use).
  [[nodiscard]] const PosteriorResult& posterior() const;
  /// The posterior mean coefficients alpha (cheap: no shape evaluation).
  [[nodiscard]] const Eigen::VectorXd& coefficients() const { return posterior_.coefficients; }
  /// The posterior covariance of alpha (n x n; the prior's identity before the first observation). Cheap.
  [[nodiscard]] Eigen::MatrixXd coefficientCovariance() const;
  /// V^p with V^model: each observation's model point and the observed point.
  [[nodiscard]] const std::vector<ModelPointObservation>& observations() const { return observations_; }

 private:
  // RMS over the paired points of the 3-dof Mahalanobis distance of each
  // feature point from its model point under the posterior predictive.
  [[nodiscard]] double contourMahalanobisRms(const ModelContour& mc, const std::vector<ContourParameter>& params,
                                             const std::vector<Eigen::Vector3d>& feature_points) const;

  // The contours of the shape at coefficients `alpha` cut by the plane, each
  // point tied to its edge. Vertices whose side of the plane the prior mean
  // and a bound decide (|n.(mu_v - p)| > sqrt(n^T Q_v Q_v^T n) |alpha|) are
  // not evaluated; only those near the plane are (O(band) instead of O(N n)).
  [[nodiscard]] std::vector<ModelContour> cutShape(const Eigen::VectorXd& alpha, const Eigen::Vector3d& plane_point,
                                                   const Eigen::Vector3d& plane_normal) const;
  [[nodiscard]] const Eigen::VectorXd& cutCoefficients() const;

  ShapeModel model_;
  ShapeTrackerOptions options_;
  // Q = U diag(sqrt(lambda)) row-major (a vertex's 3 x n block is contiguous),
  // and each vertex's Q_v Q_v^T as (xx, yy, zz, 2xy, 2xz, 2yz): n^T Q_v Q_v^T n
  // bounds how far the vertex moves along a plane's normal n.
  Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor> q_rows_;
  Eigen::Matrix<double, Eigen::Dynamic, 6, Eigen::RowMajor> vertex_gram_;
  Eigen::VectorXd zero_coefficients_;
  PosteriorNormalEquations equations_;
  mutable PosteriorResult posterior_;  // mean filled on first use after a change
  std::vector<ModelPointObservation> observations_;
  std::vector<std::uint64_t> observation_frames_;  // the frame that last renewed each observation
  std::uint64_t frames_ = 0;                       // update() calls with feature contours
  mutable Eigen::VectorXd shape_;  // posterior mean shape, valid when shape_valid_
  mutable bool shape_valid_ = false;
};

/// The cyclic shift and direction of `b` (same size as `a`) that minimise the
/// summed squared distances to `a`: K-point contours start at arbitrary
/// angles. Returns b reordered.
[[nodiscard]] std::vector<Eigen::Vector3d> alignCyclic(const std::vector<Eigen::Vector3d>& a,
                                                       const std::vector<Eigen::Vector3d>& b);

}  // namespace mrsns::deformation
