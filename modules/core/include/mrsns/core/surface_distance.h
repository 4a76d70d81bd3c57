#pragma once
// Distances between surfaces: points (or a mesh's vertices) to a triangle
// surface, and the symmetric Hausdorff distance between two meshes.
#include <Eigen/Core>

#include "mrsns/core/mesh.h"
#include "mrsns/core/mesh_locator.h"
#include "mrsns/core/mesh_ops.h"

namespace mrsns {

struct SurfaceDistanceResult {
  /// Distance (mm) of each point to the closest point on the target surface.
  Eigen::VectorXd distances;
  double mean = 0.0;
  double rms = 0.0;
  double max = 0.0;
  Eigen::Index max_index = -1;  ///< Point with the largest distance.
};

/// Distances of `points` to the surface held by `target`. Throws
/// InvalidArgumentError when `points` is empty or not finite.
[[nodiscard]] SurfaceDistanceResult pointsToSurfaceDistance(const PointsN3& points, const MeshLocator& target);

/// Same, building the locator of `target`.
[[nodiscard]] SurfaceDistanceResult pointsToSurfaceDistance(const PointsN3& points, const TriangleMesh& target);

struct SymmetricSurfaceDistance {
  SurfaceDistanceResult a_to_b;  ///< A's vertices to B's surface.
  SurfaceDistanceResult b_to_a;  ///< B's vertices to A's surface.
  /// max(a_to_b.max, b_to_a.max): the Hausdorff distance sampled at the
  /// vertices of both meshes (exact when the farthest points are vertices,
  /// otherwise a lower bound that tightens with finer tessellation).
  double hausdorff = 0.0;
  /// Mean and RMS over the vertices of both meshes together.
  double mean = 0.0;
  double rms = 0.0;
};

/// Distances in both directions between meshes in the same frame. Throws
/// FrameError when both name a frame and they differ.
[[nodiscard]] SymmetricSurfaceDistance surfaceDistance(const TriangleMesh& a, const TriangleMesh& b);

}  // namespace mrsns
