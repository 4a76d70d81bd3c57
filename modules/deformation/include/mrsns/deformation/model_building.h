#pragma once
// Building a PCA shape model from example shapes in correspondence (paper 001
// Eq. 5-6): generalised Procrustes alignment, PCA by SVD of the data matrix
// (never the 3N x 3N covariance), and the model quality figures of Styner et
// al. 2003 (compactness, generalisation by leave-one-out, specificity).

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <random>
#include <span>
#include <vector>

#include "mrsns/core/mesh.h"
#include "mrsns/core/mesh_ops.h"
#include "mrsns/core/shape_model.h"

namespace mrsns::deformation {

struct ProcrustesOptions {
  int max_iterations = 50;
  /// Stop when the mean shape moves less than this (RMS over vertices, mm).
  double tolerance_mm = 1e-6;
  /// Also remove isotropic scale (shape only); off keeps sizes in mm.
  bool estimate_scale = false;
};

struct ProcrustesResult {
  /// Each example mapped into the frame of the mean: aligned[i] = mean_T_example[i] * example[i].
  std::vector<PointsN3> aligned;
  PointsN3 mean;
  std::vector<Eigen::Affine3d> mean_T_example;
  int iterations = 0;
  bool converged = false;
  /// RMS distance of the aligned examples' vertices to the mean (mm).
  double rms_to_mean_mm = 0.0;
};

/// Generalised Procrustes analysis: aligns every example rigidly (optionally
/// with scale) to their common mean, iterating until the mean settles. The mean
/// is kept in the pose of the first example so the result stays in its frame.
/// Throws InvalidArgumentError for fewer than 2 examples or differing vertex counts.
[[nodiscard]] ProcrustesResult alignGeneralizedProcrustes(std::span<const PointsN3> examples,
                                                          const ProcrustesOptions& options = {});

struct ShapeModelBuildOptions {
  /// Align the examples by GPA first; off when they are already aligned.
  bool align = true;
  ProcrustesOptions procrustes;
  /// Noise variance of the probabilistic PCA model (mm^2), subtracted from the
  /// sample variances as statismo's PCAModelBuilder does.
  double noise_variance = 0.0;
  /// Modes with variance below this fraction of the largest are dropped.
  double min_relative_variance = 1e-12;
  /// Keep at most this many modes (<= 0: all with non-negligible variance).
  int max_modes = 0;
};

struct ShapeModelBuildResult {
  ShapeModel model;
  /// The examples as aligned shape vectors (3N x m), the data the PCA saw.
  Eigen::MatrixXd aligned_shapes;
  /// Singular values of the centred data matrix.
  Eigen::VectorXd singular_values;
  /// Total sample variance (trace of the covariance, mm^2) and the fraction kept.
  double total_variance = 0.0;
  double retained_variance_fraction = 0.0;
  int procrustes_iterations = 0;
};

/// Builds the model from meshes in correspondence (same vertex count, same
/// topology as the first, which becomes the reference). Throws
/// InvalidArgumentError for fewer than 2 examples or mismatched meshes.
[[nodiscard]] ShapeModelBuildResult buildShapeModel(std::span<const TriangleMesh> examples,
                                                    const ShapeModelBuildOptions& options = {});

/// PCA of shape vectors (columns of `shapes`, 3N x m) already aligned; the
/// reference gives the topology. The core of buildShapeModel.
[[nodiscard]] ShapeModelBuildResult buildShapeModelFromVectors(const TriangleMesh& reference,
                                                               const Eigen::MatrixXd& shapes,
                                                               const ShapeModelBuildOptions& options = {});

/// Compactness C(k): fraction of the model's total variance in the first k
/// modes, k = 1..n (entry k-1).
[[nodiscard]] Eigen::VectorXd compactness(const ShapeModel& model);

struct GeneralizationResult {
  /// Mean over left-out examples of the mean vertex distance (mm) between the
  /// example and its reconstruction with k modes (entry k-1), k = 1..m-2.
  Eigen::VectorXd mean_error_mm;
  /// Per left-out example, the error with all modes of its model (mm).
  Eigen::VectorXd leave_one_out_error_mm;
};

/// Leave-one-out generalisation: for each example, a model is built from the
/// others and the example reconstructed. `aligned_shapes` as in
/// ShapeModelBuildResult (3N x m, m >= 3).
[[nodiscard]] GeneralizationResult generalization(const TriangleMesh& reference, const Eigen::MatrixXd& aligned_shapes,
                                                  const ShapeModelBuildOptions& options = {});

struct SpecificityResult {
  /// Mean over random samples drawn with k modes of the mean vertex distance
  /// (mm) to the closest training example (entry k-1).
  Eigen::VectorXd mean_error_mm;
};

/// Specificity: samples `sample_count` shapes per k and measures how far they
/// are from the training shapes.
[[nodiscard]] SpecificityResult specificity(const ShapeModel& model, const Eigen::MatrixXd& aligned_shapes,
                                            int sample_count, std::mt19937_64& rng);

}  // namespace mrsns::deformation
