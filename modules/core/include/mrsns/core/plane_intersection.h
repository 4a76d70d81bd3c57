#pragma once
// Cutting a triangle mesh with a plane into ordered contours (e.g. the
// ultrasound image plane through a vessel model), and polyline utilities.
#include <Eigen/Core>
#include <cstdint>
#include <functional>
#include <span>
#include <vector>

#include "mrsns/core/mesh.h"

namespace mrsns {

/// An ordered sequence of 3D points (mm). A closed polyline implicitly joins
/// the last point back to the first (the first point is not repeated).
struct Polyline3d {
  std::vector<Eigen::Vector3d> points;
  bool closed = false;
};

struct PlaneCutOptions {
  /// Consecutive contour points closer than this (mm) are merged; they arise
  /// where the plane passes exactly through a mesh vertex.
  double merge_distance = 1e-12;
};

/// Intersects `mesh` with the plane through `plane_point` with normal
/// `plane_normal` (need not be unit length). Each contour follows shared mesh
/// edges, is closed when it returns to its start, and for a consistently
/// oriented mesh runs counter-clockwise about `plane_normal` around the
/// material (seen from the normal's tip). Vertices exactly on the plane are
/// treated as lying on its positive side (simulation of simplicity), so every
/// crossing is counted once. Throws InvalidArgumentError for an invalid mesh
/// or a zero/non-finite normal.
[[nodiscard]] std::vector<Polyline3d> intersectMeshWithPlane(const TriangleMesh& mesh,
                                                             const Eigen::Vector3d& plane_point,
                                                             const Eigen::Vector3d& plane_normal,
                                                             const PlaneCutOptions& options = {});

/// A point of a plane cut on the mesh edge between vertices a < b, at
/// fraction t from a: point = (1 - t) v_a + t v_b.
struct PlaneCutEdgePoint {
  std::int32_t a = -1;
  std::int32_t b = -1;
  double t = 0.0;
};

/// A contour of a plane cut with the edge of each of its points.
struct PlaneCutContour {
  Polyline3d polyline;
  std::vector<PlaneCutEdgePoint> edges;  ///< One per polyline point.
};

/// The exact position and signed distance to the plane (mm) of vertex `v`.
using PlaneCutVertexFn = std::function<void(std::int32_t v, Eigen::Vector3d& position, double& signed_distance)>;

/// The cut as intersectMeshWithPlane makes it, from the faces, the side of
/// the plane of every vertex (`positive[v]`: signed distance >= 0) and the
/// exact position and distance of a vertex on request, asked only for the
/// endpoints of crossed edges: a deformable shape can decide most sides from
/// a bound and evaluate only the vertices near the plane. Keeps each point's
/// edge. Throws InvalidArgumentError when `positive` does not cover a face's
/// vertex.
[[nodiscard]] std::vector<PlaneCutContour> cutFacesWithPlane(
    const Eigen::Matrix<std::int32_t, Eigen::Dynamic, 3, Eigen::RowMajor>& faces, std::span<const char> positive,
    const PlaneCutVertexFn& vertex, const PlaneCutOptions& options = {});

/// intersectMeshWithPlane keeping each point's edge.
[[nodiscard]] std::vector<PlaneCutContour> cutMeshWithPlane(const TriangleMesh& mesh, const Eigen::Vector3d& plane_point,
                                                            const Eigen::Vector3d& plane_normal,
                                                            const PlaneCutOptions& options = {});

/// Total length (mm), including the closing segment of a closed polyline.
[[nodiscard]] double polylineLength(const Polyline3d& polyline);

/// `count` points at uniform arc length along the polyline: for an open one
/// from its first to its last point, for a closed one starting at its first
/// point with spacing length / count. Throws InvalidArgumentError when the
/// polyline has zero length or count is too small (< 2 open, < 1 closed).
[[nodiscard]] Polyline3d resamplePolyline(const Polyline3d& polyline, int count);

}  // namespace mrsns
