#pragma once
// Contours in an ultrasound slice: the cut of the current model with the image
// plane (each point tied to the model's vertices, so it can be conditioned on),
// and the near arc-length parameterisation of paper 001 Eq. 8 that resamples
// feature and intersection contours to the same K points.

#include <Eigen/Core>
#include <vector>

#include "mrsns/core/mesh.h"
#include "mrsns/core/plane_intersection.h"
#include "mrsns/deformation/posterior.h"

namespace mrsns::deformation {

/// Where a resampled point lies on a polyline: between raw points `index` and
/// index + 1 (wrapping for a closed polyline) at fraction `u` in [0, 1].
struct ContourParameter {
  int index = 0;
  double u = 0.0;
};

/// Eq. 8: `count` parameters at (nearly) uniform arc length. The arc length
/// S(t) over the raw points (t_i = i) is approximated piecewise by the linear
/// rational function s_i(t) with weights W_i from the ratio of neighbouring
/// chord speeds, and inverted in closed form. A closed polyline starts at its
/// first point with spacing length / count; an open one runs end to end.
/// Throws InvalidArgumentError for fewer than 2 points, zero length or a
/// count below 2 (open) / 3 (closed).
[[nodiscard]] std::vector<ContourParameter> nearArcLengthParameters(const Polyline3d& polyline, int count);

/// The points of nearArcLengthParameters, by linear interpolation of the raw
/// points (exactly on the polyline).
[[nodiscard]] Polyline3d resampleNearArcLength(const Polyline3d& polyline, int count);

/// A contour of a model shape cut by a plane; `points[i]` lies on the mesh
/// edge between vertices edge_vertices[i] (weights 1 - t, t).
struct ModelContour {
  Polyline3d contour;
  std::vector<Eigen::Vector2i> edge_vertices;
  std::vector<double> edge_t;

  /// The model point at a resampling parameter: a combination of up to 4
  /// vertices (two edge points), with `point` set to its current position.
  [[nodiscard]] ModelPointObservation modelPoint(const ContourParameter& p) const;
};

/// Cuts `mesh` with the plane (via intersectMeshWithPlane) and records for
/// every contour point the mesh edge it lies on. Throws as intersectMeshWithPlane.
[[nodiscard]] std::vector<ModelContour> cutModelWithPlane(const TriangleMesh& mesh, const Eigen::Vector3d& plane_point,
                                                          const Eigen::Vector3d& plane_normal);

/// Mean of the points of a polyline.
[[nodiscard]] Eigen::Vector3d polylineCentroid(const Polyline3d& polyline);

}  // namespace mrsns::deformation
