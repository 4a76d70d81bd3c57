#pragma once
// Surface registration: iterative closest point (ICP) of a point set (e.g.
// points digitised on the patient, or a surface from another scan) onto a
// triangle surface, point-to-point (Besl & McKay 1992) or point-to-plane
// (Chen & Medioni 1992), with the closest point on the triangles (not the
// nearest vertex) from a BVH, and the outlier handling real data needs:
// rejection beyond a distance, trimming to the best fraction (Chetverikov
// 2002), and robust Huber/Tukey weights whose scale comes from the median
// absolute deviation of the residuals. Initial alignments from landmarks or
// from the principal axes.
//
// Deterministic: no random numbers, and the closest-point queries (the only
// parallel part) are gathered in point order, so the same input gives the
// same bits with any number of threads.
#include <Eigen/Geometry>
#include <limits>
#include <memory>
#include <span>
#include <vector>

#include "mrsns/core/mesh.h"
#include "mrsns/core/mesh_locator.h"
#include "mrsns/core/mesh_ops.h"

namespace mrsns::registration {

enum class IcpMethod {
  PointToPoint,  ///< minimises sum |R p + t - q|^2 (closed form, slow near convergence)
  /// minimises sum (n . (R p + t - q))^2 (linearised; few iterations on smooth surfaces), n the gradient of
  /// the distance to the surface: the face's normal, or the direction to q when q is on an edge or corner
  PointToPlane,
};

enum class RobustLoss { None, Huber, Tukey };

struct IcpOptions {
  IcpMethod method = IcpMethod::PointToPlane;
  int max_iterations = 100;
  /// Correspondences farther than this (mm) are ignored; infinite keeps all.
  double max_correspondence_distance_mm = std::numeric_limits<double>::infinity();
  /// Fraction of all moving points kept as correspondences, the closest
  /// first (points beyond the distance count as dropped); 1 keeps all. Use
  /// about 1 - expected outlier fraction.
  double trim_fraction = 1.0;
  RobustLoss loss = RobustLoss::None;
  /// Tuning constant of the loss in units of the robust scale; <= 0 picks
  /// the usual 95%-efficiency value (Huber 1.345, Tukey 4.685).
  double robust_k = 0.0;
  /// Lower bound of the robust scale (1.4826 * MAD, mm): keeps weights sane
  /// when the residuals are almost all zero (noise-free data).
  double min_robust_scale_mm = 0.01;
  /// Point-to-plane only: start with point-to-point steps (wider basin of
  /// convergence) until a step moves the points by less than this times their
  /// RMS distance to the surface; 0 uses point-to-plane from the start.
  double point_to_point_warmup_ratio = 0.5;
  /// ... or once a point-to-point step rotates by less than this (rad) and
  /// moves the centroid by less than a tenth of the points' RMS spread: from
  /// there the remaining error is well within point-to-plane's basin (a
  /// 45 deg start still converges; the slow point-to-point crawl to the
  /// noise floor is skipped). 0 keeps only the ratio test.
  double warmup_rotation_rad = 2.0 * 3.14159265358979323846 / 180.0;
  /// Converged when one iteration moves every point by less than this (mm),
  /// estimated over the points' bounding radius; the result is then the
  /// transform that step started from (its figures are already at hand).
  double motion_tolerance_mm = 1e-4;
  /// ... or when the weighted RMS changes by less than this fraction.
  double relative_rms_tolerance = 1e-7;
  /// Threads for the closest-point queries (0 = the hardware's); the result
  /// does not depend on it.
  unsigned threads = 0;
  /// With 4000 points or more, iterate on a subset spread like all points
  /// (every 4th in space; every 16th first from 16,000 points, every 64th
  /// from 64,000: at least 1000 points each) until converged, then on the
  /// next larger subset, and last on all points until converged again: the
  /// result is all points' fixed point either way.
  bool coarse_to_fine = true;
};

struct IcpResult {
  /// Maps the moving points into the surface's frame.
  Eigen::Isometry3d fixed_T_moving = Eigen::Isometry3d::Identity();
  /// RMS distance of the inliers to the surface at the result (mm).
  double rms_mm = 0.0;
  /// Weighted RMS distance of the first iteration's correspondences (after
  /// rejection, trimming and weighting) at the start (mm); with
  /// coarse_to_fine on 4000 points or more, over the subset of the points
  /// the first iteration uses.
  double initial_rms_mm = 0.0;
  /// inliers.size() / number of points.
  double inlier_fraction = 0.0;
  /// Moving points used in the last iteration (within the distance, kept by
  /// trimming, non-zero weight), ascending.
  std::vector<int> inliers;
  int iterations = 0;
  /// False when max_iterations ran out first.
  bool converged = false;
  /// Distance of every moving point to the surface at the result (mm).
  std::vector<double> distances_mm;
};

/// The fixed surface prepared once for many registrations (BVH and face
/// normals). Throws InvalidArgumentError for an invalid or empty mesh.
class IcpSurface {
 public:
  explicit IcpSurface(const TriangleMesh& mesh);
  [[nodiscard]] const MeshLocator& locator() const { return *locator_; }
  [[nodiscard]] const PointsN3& faceNormals() const { return locator_->faceNormals(); }
  /// Area-weighted centroid and covariance of the surface (uniform density
  /// over the triangles, so independent of the tessellation).
  [[nodiscard]] const Eigen::Vector3d& surfaceCentroid() const { return centroid_; }
  [[nodiscard]] const Eigen::Matrix3d& surfaceCovariance() const { return covariance_; }

 private:
  std::shared_ptr<const MeshLocator> locator_;
  Eigen::Vector3d centroid_ = Eigen::Vector3d::Zero();
  Eigen::Matrix3d covariance_ = Eigen::Matrix3d::Zero();
};

/// ICP of `moving` onto `fixed` from `initial_fixed_T_moving`. Throws
/// InvalidArgumentError for NaN/inf points, fewer than 3 points or invalid
/// options, ComputationError when fewer than 3 correspondences survive
/// (start too far: give an initial alignment or a larger distance).
IcpResult registerSurface(std::span<const Eigen::Vector3d> moving, const IcpSurface& fixed,
                          const Eigen::Isometry3d& initial_fixed_T_moving = Eigen::Isometry3d::Identity(),
                          const IcpOptions& options = {});

/// Same, building the surface from a mesh.
IcpResult registerSurface(std::span<const Eigen::Vector3d> moving, const TriangleMesh& fixed,
                          const Eigen::Isometry3d& initial_fixed_T_moving = Eigen::Isometry3d::Identity(),
                          const IcpOptions& options = {});

/// Rigid initial alignment from paired landmarks (registerPairedPoints, no
/// scale). Throws as registerPairedPoints does.
Eigen::Isometry3d initialAlignmentFromLandmarks(std::span<const Eigen::Vector3d> moving_landmarks,
                                                std::span<const Eigen::Vector3d> fixed_landmarks);

struct PrincipalAxesOptions {
  /// Each of the 4 sign-ambiguous candidates is refined by this many ICP
  /// iterations (with `icp`) before they are compared; 0 compares them as they are.
  int refine_iterations = 15;
  IcpOptions icp = [] {
    IcpOptions o;
    o.trim_fraction = 0.9;
    return o;
  }();
};

struct PrincipalAxesResult {
  /// The best candidate (unrefined: centroids and principal axes matched).
  Eigen::Isometry3d fixed_T_moving = Eigen::Isometry3d::Identity();
  /// Trimmed RMS of each candidate after refinement (mm), and the chosen one.
  std::vector<double> candidate_rms_mm;
  int chosen = 0;
  /// Principal standard deviations (mm), largest first, of the points and the surface.
  Eigen::Vector3d moving_extent_mm = Eigen::Vector3d::Zero();
  Eigen::Vector3d fixed_extent_mm = Eigen::Vector3d::Zero();
};

/// Alignment of the points' centroid and principal axes with those of the
/// surface (area-weighted, so a mesh with crowded vertices, e.g. at the poles
/// of a UV sphere, does not skew them), trying the 4 proper-rotation sign choices of the axes
/// and keeping the one that fits best. Needs points covering about the same
/// part of the shape as the mesh, with distinct principal extents. Throws
/// InvalidArgumentError for bad points, ComputationError for a degenerate
/// (planar or linear) point set.
PrincipalAxesResult initialAlignmentFromPrincipalAxes(std::span<const Eigen::Vector3d> moving, const IcpSurface& fixed,
                                                      const PrincipalAxesOptions& options = {});

}  // namespace mrsns::registration
