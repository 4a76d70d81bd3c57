#include "mrsns/deformation/contour_features.h"

#include <algorithm>
#include <cmath>

#include "mrsns/core/error.h"

namespace mrsns::deformation {

std::vector<ContourParameter> nearArcLengthParameters(const Polyline3d& polyline, int count) {
  const int n = static_cast<int>(polyline.points.size());
  const bool closed = polyline.closed;
  if (n < 2 || count < (closed ? 3 : 2)) {
    throw InvalidArgumentError(
        "nearArcLengthParameters: need >= 2 points and count >= " + std::string(closed ? "3 (closed)" : "2 (open)") +
        ", got " + std::to_string(n) + " points, count " + std::to_string(count));
  }
  const int segments = closed ? n : n - 1;
  // Chord lengths dS_i of segment i (raw points i -> i+1), t-spacing 1.
  std::vector<double> ds(static_cast<std::size_t>(segments));
  std::vector<double> s(static_cast<std::size_t>(segments) + 1, 0.0);
  for (int i = 0; i < segments; ++i) {
    ds[static_cast<std::size_t>(i)] =
        (polyline.points[static_cast<std::size_t>((i + 1) % n)] - polyline.points[static_cast<std::size_t>(i)]).norm();
    s[static_cast<std::size_t>(i) + 1] = s[static_cast<std::size_t>(i)] + ds[static_cast<std::size_t>(i)];
  }
  const double length = s.back();
  if (!(length > 0.0) || !std::isfinite(length)) {
    throw InvalidArgumentError("nearArcLengthParameters: polyline has zero or non-finite length");
  }
  // Eq. 8 weights: W_i / W_{i-1} = (dS_i/dt_i) / (dS_{i+1}/dt_{i+1}). Only the
  // ratio within a segment enters, so each is kept as a ratio (no overflow of
  // the running product). The last segment of an open polyline has no
  // successor: ratio 1 (plain chord length).
  std::vector<double> ratio(static_cast<std::size_t>(segments), 1.0);
  for (int i = 0; i < segments; ++i) {
    const int next = i + 1;
    if (next >= segments && !closed) break;
    const double a = ds[static_cast<std::size_t>(i)];
    const double b = ds[static_cast<std::size_t>(next % segments)];
    if (a > 0.0 && b > 0.0) ratio[static_cast<std::size_t>(i)] = std::clamp(a / b, 0.1, 10.0);
  }
  std::vector<ContourParameter> out;
  out.reserve(static_cast<std::size_t>(count));
  const double step = closed ? length / count : length / (count - 1);
  int seg = 0;
  for (int k = 0; k < count; ++k) {
    const double target = std::min(k * step, length);
    while (seg < segments - 1 && s[static_cast<std::size_t>(seg) + 1] < target) ++seg;
    const double s0 = s[static_cast<std::size_t>(seg)];
    const double s1 = s[static_cast<std::size_t>(seg) + 1];
    // s(u) = (S0 (1-u) + r S1 u) / ((1-u) + r u), inverted for u.
    const double r = ratio[static_cast<std::size_t>(seg)];
    const double a = target - s0;
    const double b = s1 - target;
    const double denom = a + r * b;
    double u = denom > 0.0 ? a / denom : 0.0;
    // With r != 1 the rational map is monotone but not linear: u maps the
    // target into the segment consistently with neighbouring segments.
    u = std::clamp(u, 0.0, 1.0);
    out.push_back({seg, u});
  }
  return out;
}

Polyline3d resampleNearArcLength(const Polyline3d& polyline, int count) {
  const auto params = nearArcLengthParameters(polyline, count);
  const int n = static_cast<int>(polyline.points.size());
  Polyline3d out;
  out.closed = polyline.closed;
  for (const auto& p : params) {
    const Eigen::Vector3d& a = polyline.points[static_cast<std::size_t>(p.index)];
    const Eigen::Vector3d& b = polyline.points[static_cast<std::size_t>((p.index + 1) % n)];
    out.points.push_back(a + p.u * (b - a));
  }
  return out;
}

ModelPointObservation ModelContour::modelPoint(const ContourParameter& p) const {
  const int n = static_cast<int>(contour.points.size());
  const int j = (p.index + 1) % n;
  const auto i0 = static_cast<std::size_t>(p.index);
  const auto i1 = static_cast<std::size_t>(j);
  ModelPointObservation o;
  o.vertices = {edge_vertices[i0][0], edge_vertices[i0][1], edge_vertices[i1][0], edge_vertices[i1][1]};
  o.weights = Eigen::Vector4d((1.0 - p.u) * (1.0 - edge_t[i0]), (1.0 - p.u) * edge_t[i0], p.u * (1.0 - edge_t[i1]),
                              p.u * edge_t[i1]);
  o.point = contour.points[i0] + p.u * (contour.points[i1] - contour.points[i0]);
  return o;
}

std::vector<ModelContour> cutModelWithPlane(const TriangleMesh& mesh, const Eigen::Vector3d& plane_point,
                                            const Eigen::Vector3d& plane_normal) {
  std::vector<ModelContour> out;
  for (auto& c : cutMeshWithPlane(mesh, plane_point, plane_normal)) {
    if (c.polyline.points.size() < 3) continue;
    ModelContour mc;
    mc.contour = std::move(c.polyline);
    for (const auto& e : c.edges) {
      mc.edge_vertices.emplace_back(e.a, e.b);
      mc.edge_t.push_back(e.t);
    }
    out.push_back(std::move(mc));
  }
  return out;
}

Eigen::Vector3d polylineCentroid(const Polyline3d& polyline) {
  Eigen::Vector3d c = Eigen::Vector3d::Zero();
  for (const auto& p : polyline.points) c += p;
  return polyline.points.empty() ? c : Eigen::Vector3d(c / static_cast<double>(polyline.points.size()));
}

}  // namespace mrsns::deformation
