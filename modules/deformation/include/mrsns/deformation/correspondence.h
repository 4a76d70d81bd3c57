#pragma once
// Correspondence for meshes that do not share vertices (paper 001, the step
// before Eq. 5-6): the reference mesh is aligned to each example (landmarks
// or principal axes, then ICP and an isotropic scale), then fitted to it
// non-rigidly, so every example is re-expressed with the reference's
// vertices and topology and a PCA model can be built from them.
//
// The non-rigid stage is a non-rigid ICP with a stiffness schedule in the
// spirit of Amberg et al. 2007 (CVPR, "Optimal step nonrigid ICP"), with a
// per-vertex translation instead of a per-vertex affine map: it minimises
//   sum_i w_i |x_i + d_i - c_i|^2 + alpha sum_(i,j) in edges |d_i - d_j|^2
// over the displacement field d (the whole field from the rigidly aligned
// reference x, not an increment, so the stiffness bounds the total bend),
// one sparse symmetric positive definite N x N solve per iteration, for a
// decreasing alpha. Correspondences c_i go both ways: each reference vertex
// to its closest point on the example, and each example vertex to its
// nearest reference vertex (so protrusions of the example are reached), with
// a distance and a normal-compatibility test.

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <limits>
#include <span>
#include <vector>

#include "mrsns/core/mesh.h"
#include "mrsns/core/surface_distance.h"

namespace mrsns::deformation {

struct NonRigidFitOptions {
  /// Rigid stage: estimate an isotropic scale after ICP (examples from
  /// different patients differ in size; the PCA then sees size as shape).
  bool estimate_scale = true;
  int rigid_iterations = 30;
  /// Stiffness schedule alpha (in units of the data weight per vertex, over
  /// graph edges: displacements stay smooth over about sqrt(alpha) edges).
  std::vector<double> stiffness = {3000.0, 1000.0, 300.0, 100.0, 30.0, 10.0, 3.0, 1.0};
  int iterations_per_stiffness = 3;
  /// Correspondences farther than this are ignored (mm); <= 0 picks 5 times
  /// the reference's mean edge length plus the rigid stage's RMS distance.
  double max_distance_mm = 0.0;
  /// Correspondences whose normals differ by more than this are ignored (rad).
  double max_normal_angle_rad = 1.0472;  // 60 deg
  /// Also pull the reference towards every example vertex (weight per pull
  /// scaled by N_reference / N_example so both directions count alike).
  bool symmetric = true;
  /// Weight of the landmark pairs in the non-rigid stage (0: landmarks only
  /// start the rigid stage, so the landmark error stays an independent check).
  double landmark_weight = 0.0;
};

struct NonRigidFitResult {
  /// The reference's topology with its vertices fitted to the example, in the example's frame.
  TriangleMesh fitted;
  /// The rigid stage: example_T_reference, a similarity when the scale is estimated.
  Eigen::Affine3d example_T_reference = Eigen::Affine3d::Identity();
  double scale = 1.0;
  /// Fitted vertices to the example's surface, and the example's vertices to
  /// the fitted surface (mm): both must be small for a fit.
  SurfaceDistanceResult fitted_to_example;
  SurfaceDistanceResult example_to_fitted;
  /// The same after the rigid stage only.
  double rigid_mean_distance_mm = 0.0;
  /// Landmarks (when given): the reference vertex nearest each reference
  /// landmark, and its distance to the example's landmark after the rigid
  /// stage and after the fit (mm).
  std::vector<int> landmark_vertices;
  std::vector<double> rigid_landmark_error_mm;
  std::vector<double> landmark_error_mm;
  double mean_edge_length_mm = 0.0;
  int iterations = 0;
};

/// Fits `reference` to `example`. Landmarks are optional (both empty, or the
/// same count >= 3, paired by order; reference landmarks in the reference's
/// frame). Throws InvalidArgumentError for empty/invalid meshes, mismatched
/// landmarks or an empty stiffness schedule; ComputationError when the rigid
/// stage cannot find enough correspondences.
[[nodiscard]] NonRigidFitResult fitReferenceToExample(const TriangleMesh& reference, const TriangleMesh& example,
                                                      const NonRigidFitOptions& options = {},
                                                      std::span<const Eigen::Vector3d> reference_landmarks = {},
                                                      std::span<const Eigen::Vector3d> example_landmarks = {});

/// The reference fitted to every example: meshes in correspondence (the
/// reference's topology), ready for buildShapeModel. `example_landmarks`,
/// when not empty, holds one set per example, paired with `reference_landmarks`.
[[nodiscard]] std::vector<NonRigidFitResult> establishCorrespondence(
    const TriangleMesh& reference, std::span<const TriangleMesh> examples, const NonRigidFitOptions& options = {},
    std::span<const std::vector<Eigen::Vector3d>> example_landmarks = {},
    std::span<const Eigen::Vector3d> reference_landmarks = {});

}  // namespace mrsns::deformation
