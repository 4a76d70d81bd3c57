#include "mrsns/core/surface_distance.h"

#include <algorithm>
#include <cmath>
#include <string>

#include "mrsns/core/error.h"

namespace mrsns {

SurfaceDistanceResult pointsToSurfaceDistance(const PointsN3& points, const MeshLocator& target) {
  if (points.rows() == 0) {
    throw InvalidArgumentError("pointsToSurfaceDistance: no points given; pass at least one point");
  }
  if (!points.allFinite()) {
    throw InvalidArgumentError("pointsToSurfaceDistance: some points are NaN or infinite; remove them first");
  }
  SurfaceDistanceResult result;
  result.distances.resize(points.rows());
  for (Eigen::Index i = 0; i < points.rows(); ++i) {
    result.distances(i) = target.closestPoint(points.row(i).transpose()).distance;
  }
  result.mean = result.distances.mean();
  result.rms = std::sqrt(result.distances.squaredNorm() / static_cast<double>(points.rows()));
  result.max = result.distances.maxCoeff(&result.max_index);
  return result;
}

SurfaceDistanceResult pointsToSurfaceDistance(const PointsN3& points, const TriangleMesh& target) {
  return pointsToSurfaceDistance(points, MeshLocator(target));
}

SymmetricSurfaceDistance surfaceDistance(const TriangleMesh& a, const TriangleMesh& b) {
  if (!a.frame.empty() && !b.frame.empty() && a.frame != b.frame) {
    throw FrameError("surfaceDistance: mesh '" + a.name + "' is in frame '" + a.frame + "' but mesh '" + b.name +
                     "' is in frame '" + b.frame + "'; transform one into the other's frame first");
  }
  const MeshLocator locator_a(a);
  const MeshLocator locator_b(b);
  SymmetricSurfaceDistance result;
  result.a_to_b = pointsToSurfaceDistance(a.vertices, locator_b);
  result.b_to_a = pointsToSurfaceDistance(b.vertices, locator_a);
  result.hausdorff = std::max(result.a_to_b.max, result.b_to_a.max);
  const auto na = static_cast<double>(a.vertexCount());
  const auto nb = static_cast<double>(b.vertexCount());
  result.mean = (result.a_to_b.distances.sum() + result.b_to_a.distances.sum()) / (na + nb);
  result.rms = std::sqrt((result.a_to_b.distances.squaredNorm() + result.b_to_a.distances.squaredNorm()) / (na + nb));
  return result;
}

}  // namespace mrsns
