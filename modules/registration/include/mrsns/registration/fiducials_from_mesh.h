#pragma once
// Fiducial screws found in CT meshes (paper 000, section 2.5): the vertices of
// the segmented screw mesh are clustered by k-means into one cluster per
// screw, each cluster's first principal axis is the screw axis, and the
// landmark is where that axis meets the bone surface (where the screw enters
// the bone, the point a pointer touches).
#include <Eigen/Core>
#include <cstdint>
#include <string>
#include <vector>

#include "mrsns/core/image.h"
#include "mrsns/core/landmarks.h"
#include "mrsns/core/mesh.h"
#include "mrsns/core/mesh_ops.h"

namespace mrsns::registration {

struct KMeansOptions {
  int restarts = 8;          ///< independent k-means++ starts; the lowest inertia wins
  int max_iterations = 100;  ///< Lloyd iterations per start
  std::uint64_t seed = 20260101;
};

struct KMeansResult {
  PointsN3 centres;         ///< K rows
  std::vector<int> labels;  ///< cluster of each point
  std::vector<int> sizes;   ///< points per cluster
  double inertia = 0.0;     ///< sum of squared distances to the centres (mm^2)
  int iterations = 0;       ///< of the winning start
};

/// k-means with k-means++ seeding (Arthur & Vassilvitskii 2007), seeded and
/// deterministic; clusters are ordered by their centre (x, then y, then z) so
/// the output does not depend on the start that won. Throws
/// InvalidArgumentError for k < 1, k larger than the number of points, NaN
/// points or bad options.
KMeansResult kMeans(const PointsN3& points, int k, const KMeansOptions& options = {});

struct FiducialsFromMeshOptions {
  KMeansOptions kmeans;
  /// A hit of the axis with the bone farther than this from the cluster's
  /// axial extent is ignored (mm); then the fallback is used.
  double max_hit_distance_mm = 10.0;
  /// Elongation (sqrt of the first over the second eigenvalue) at which the
  /// axis counts as fully trustworthy.
  double good_elongation = 2.0;
  /// Also estimate where the axis meets the bone from the bone surface
  /// around the screw (a quadric fitted to the bone vertices in a ring
  /// `ring_width_mm` wide just outside the screw's radius), and use that
  /// estimate when the axis's own crossing lies more than
  /// `surface_agreement_mm` from it. A bone segmented with the screw as a
  /// separate label has a tunnel where the screw sits: the axis then crosses
  /// the bone only at the tunnel's bottom, the screw's tip, not where it
  /// enters the bone.
  bool entry_from_surrounding_surface = false;
  double ring_width_mm = 4.0;
  double surface_agreement_mm = 1.0;
};

struct DetectedFiducial {
  std::string label;
  /// The landmark (LPS mm): axis/bone intersection, or the screw-head end
  /// point when the axis misses the bone.
  Eigen::Vector3d position = Eigen::Vector3d::Zero();
  /// Unit screw axis, pointing out of the bone towards the head.
  Eigen::Vector3d axis = Eigen::Vector3d::UnitZ();
  Eigen::Vector3d cluster_centroid = Eigen::Vector3d::Zero();
  Eigen::Vector3d head_point = Eigen::Vector3d::Zero();  ///< outermost cluster point along the axis
  int vertex_count = 0;
  /// sqrt(lambda1 / lambda2) of the cluster: 1 for a blob, large for a pin.
  double elongation = 0.0;
  /// min(size, mean size) / max(size, mean size): low when a cluster took two screws or half of one.
  double size_balance = 0.0;
  /// Distance along the axis from the cluster's extent to the bone hit (0 inside the extent); NaN without a hit.
  double hit_distance_mm = 0.0;
  bool axis_hits_bone = false;
  /// "axis" (the axis's crossing with the bone), "surrounding surface" (the
  /// quadric fitted around the screw) or "head" (neither: the head's end point).
  std::string entry_from = "axis";
  /// Product of the three scores above, in [0, 1].
  double confidence = 0.0;
};

struct FiducialsFromMeshResult {
  std::vector<DetectedFiducial> fiducials;
  KMeansResult clusters;
};

/// Finds `count` fiducial screws in `screws` (the vertices are used) and
/// their entry points on `bone`. Throws InvalidArgumentError for empty or
/// invalid meshes, count < 1 or count larger than the screw vertex count.
FiducialsFromMeshResult findFiducialsFromMeshes(const TriangleMesh& screws, const TriangleMesh& bone, int count,
                                                const FiducialsFromMeshOptions& options = {});

struct FiducialScrewsInMaskOptions {
  /// Screws to find; 0: one per connected region of the mask (26-neighbour).
  int count = 0;
  /// Regions smaller than this are noise, not screws (partial-volume specks).
  std::size_t min_voxels = 4;
  FiducialsFromMeshOptions mesh{.kmeans = {}, .max_hit_distance_mm = 10.0, .good_elongation = 2.0,
                                .entry_from_surrounding_surface = true, .ring_width_mm = 3.0,
                                .surface_agreement_mm = 1.0};
};

struct FiducialScrewsInMaskResult {
  FiducialsFromMeshResult found;
  int regions = 0;                         ///< connected regions of at least min_voxels
  std::vector<std::size_t> region_voxels;  ///< their sizes, largest first
};

/// Fiducial screws in a binary mask on an image's grid (a screw or marker
/// label, or metal above a threshold in the CT): its connected regions
/// counted, the mask meshed without smoothing, one cluster per screw, and
/// each landmark where the screw's axis meets `bone`. Throws
/// InvalidArgumentError for an empty mask or bone, ComputationError when the
/// mask has fewer regions than `count` asks for, or none.
FiducialScrewsInMaskResult findFiducialScrewsInMask(const ImageVolume& mask, const TriangleMesh& bone,
                                                    const FiducialScrewsInMaskOptions& options = {});

/// The fiducials as landmarks "F-1".. with confidence in the description; frame from `frame`.
LandmarkSet fiducialLandmarks(const FiducialsFromMeshResult& result, const std::string& frame = {});

}  // namespace mrsns::registration
