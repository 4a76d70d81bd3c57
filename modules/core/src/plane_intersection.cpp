#include "mrsns/core/plane_intersection.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <string>
#include <unordered_map>

#include "mrsns/core/error.h"
#include "mrsns/core/mesh_ops.h"

namespace mrsns {
namespace {

struct Segment {
  std::int32_t from = -1;  // node on the face's "+ to -" edge
  std::int32_t to = -1;    // node on the face's "- to +" edge
};

// Walks a chain of segments starting at `start`, marking them used; returns
// the node sequence and how many segments were walked along their direction.
std::vector<std::int32_t> walk(std::int32_t start, const std::vector<Segment>& segments,
                               const std::vector<std::vector<std::int32_t>>& incident, std::vector<char>& used,
                               int& forward_votes) {
  std::vector<std::int32_t> nodes{start};
  std::int32_t current = start;
  for (;;) {
    std::int32_t next_segment = -1;
    for (const std::int32_t s : incident[static_cast<std::size_t>(current)]) {
      if (!used[static_cast<std::size_t>(s)]) {
        next_segment = s;
        break;
      }
    }
    if (next_segment < 0) break;
    used[static_cast<std::size_t>(next_segment)] = 1;
    const Segment& seg = segments[static_cast<std::size_t>(next_segment)];
    const bool forward = seg.from == current;
    forward_votes += forward ? 1 : -1;
    current = forward ? seg.to : seg.from;
    nodes.push_back(current);
    if (current == start) break;
  }
  return nodes;
}

}  // namespace

std::vector<PlaneCutContour> cutFacesWithPlane(
    const Eigen::Matrix<std::int32_t, Eigen::Dynamic, 3, Eigen::RowMajor>& faces, std::span<const char> positive,
    const PlaneCutVertexFn& vertex, const PlaneCutOptions& options) {
  const auto nv = static_cast<std::int64_t>(positive.size());
  // Every index checked once, up front: the face loop below is the hot part
  // of a live frame's cut (tens of thousands of faces, a few hundred crossed).
  std::int32_t lowest = 0, highest = 0;
  for (Eigen::Index i = 0; i < faces.size(); ++i) {  // one pass, both ends (vectorised)
    lowest = std::min(lowest, faces.data()[i]);
    highest = std::max(highest, faces.data()[i]);
  }
  if (lowest < 0 || highest >= nv) {
    throw InvalidArgumentError("cutFacesWithPlane: a face refers to vertex " +
                               std::to_string(lowest < 0 ? lowest : highest) + " of " + std::to_string(nv));
  }
  // A vertex on the plane counts as positive: each edge then either crosses
  // or not, with no third case, and the contour passes through that vertex.
  const char* side = positive.data();

  std::unordered_map<std::int64_t, std::int32_t> node_of_edge;
  std::vector<Eigen::Vector3d> node_points;
  std::vector<PlaneCutEdgePoint> node_edges;
  auto nodeOnEdge = [&](std::int32_t a, std::int32_t b) {
    if (a > b) std::swap(a, b);  // canonical order: both faces compute the same point
    const std::int64_t key = static_cast<std::int64_t>(a) * nv + b;
    const auto [it, inserted] = node_of_edge.try_emplace(key, static_cast<std::int32_t>(node_points.size()));
    if (inserted) {
      Eigen::Vector3d va, vb;
      double da = 0.0, db = 0.0;
      vertex(a, va, da);
      vertex(b, vb, db);
      // The sides came from the caller; a distance that disagrees by round-off
      // (a vertex on the plane) is clamped so the point stays on the edge.
      const double t = da == db ? 0.0 : std::clamp(da / (da - db), 0.0, 1.0);
      node_points.push_back(va + t * (vb - va));
      node_edges.push_back({a, b, t});
    }
    return it->second;
  };

  std::vector<Segment> segments;
  for (Eigen::Index f = 0; f < faces.rows(); ++f) {
    const std::int32_t v[3] = {faces(f, 0), faces(f, 1), faces(f, 2)};
    const bool p[3] = {side[v[0]] != 0, side[v[1]] != 0, side[v[2]] != 0};
    if (p[0] == p[1] && p[1] == p[2]) continue;  // the face does not cross the plane
    Segment seg;
    for (int k = 0; k < 3; ++k) {
      const int k1 = k == 2 ? 0 : k + 1;
      if (p[k] && !p[k1]) seg.from = nodeOnEdge(v[k], v[k1]);
      if (!p[k] && p[k1]) seg.to = nodeOnEdge(v[k], v[k1]);
    }
    if (seg.from >= 0 && seg.to >= 0) segments.push_back(seg);
  }

  std::vector<std::vector<std::int32_t>> incident(node_points.size());
  for (std::size_t s = 0; s < segments.size(); ++s) {
    incident[static_cast<std::size_t>(segments[s].from)].push_back(static_cast<std::int32_t>(s));
    incident[static_cast<std::size_t>(segments[s].to)].push_back(static_cast<std::int32_t>(s));
  }

  std::vector<char> used(segments.size(), 0);
  std::vector<PlaneCutContour> contours;
  auto emit = [&](std::int32_t start) {
    int votes = 0;
    std::vector<std::int32_t> nodes = walk(start, segments, incident, used, votes);
    if (nodes.size() < 2) return;
    PlaneCutContour c;
    Polyline3d& line = c.polyline;
    line.closed = nodes.size() > 2 && nodes.back() == nodes.front();
    if (line.closed) nodes.pop_back();
    for (const std::int32_t node : nodes) {
      const Eigen::Vector3d& p = node_points[static_cast<std::size_t>(node)];
      if (!line.points.empty() && (p - line.points.back()).norm() <= options.merge_distance) continue;
      line.points.push_back(p);
      c.edges.push_back(node_edges[static_cast<std::size_t>(node)]);
    }
    if (line.closed && line.points.size() > 1 &&
        (line.points.back() - line.points.front()).norm() <= options.merge_distance) {
      line.points.pop_back();
      c.edges.pop_back();
    }
    if (line.points.size() < 2) return;  // the plane only touched the mesh at a point
    if (votes < 0) {
      std::reverse(line.points.begin(), line.points.end());
      std::reverse(c.edges.begin(), c.edges.end());
    }
    contours.push_back(std::move(c));
  };
  // Open chains first (they start at a node with one segment, on a mesh
  // boundary), so a loop walk never starts in the middle of a chain.
  for (std::size_t node = 0; node < incident.size(); ++node) {
    if (incident[node].size() % 2 == 1) {
      const bool pending = std::any_of(incident[node].begin(), incident[node].end(),
                                       [&](std::int32_t s) { return !used[static_cast<std::size_t>(s)]; });
      if (pending) emit(static_cast<std::int32_t>(node));
    }
  }
  for (std::size_t s = 0; s < segments.size(); ++s) {
    if (!used[s]) emit(segments[s].from);
  }
  return contours;
}

std::vector<PlaneCutContour> cutMeshWithPlane(const TriangleMesh& mesh, const Eigen::Vector3d& plane_point,
                                              const Eigen::Vector3d& plane_normal, const PlaneCutOptions& options) {
  validateMesh(mesh, mesh.name.empty() ? std::string("intersectMeshWithPlane mesh")
                                       : "intersectMeshWithPlane mesh '" + mesh.name + "'");
  if (!plane_point.allFinite() || !plane_normal.allFinite() || !(plane_normal.squaredNorm() > 0.0)) {
    throw InvalidArgumentError(
        "intersectMeshWithPlane: the plane point and normal must be finite and the normal non-zero");
  }
  const Eigen::Vector3d n = plane_normal.normalized();
  const Eigen::VectorXd d = (mesh.vertices.rowwise() - plane_point.transpose()) * n;
  std::vector<char> positive(static_cast<std::size_t>(d.size()));
  for (Eigen::Index v = 0; v < d.size(); ++v) positive[static_cast<std::size_t>(v)] = d(v) >= 0.0 ? 1 : 0;
  return cutFacesWithPlane(
      mesh.faces, positive,
      [&](std::int32_t v, Eigen::Vector3d& position, double& distance) {
        position = mesh.vertices.row(v).transpose();
        distance = d(v);
      },
      options);
}

std::vector<Polyline3d> intersectMeshWithPlane(const TriangleMesh& mesh, const Eigen::Vector3d& plane_point,
                                               const Eigen::Vector3d& plane_normal, const PlaneCutOptions& options) {
  std::vector<Polyline3d> out;
  for (auto& c : cutMeshWithPlane(mesh, plane_point, plane_normal, options)) out.push_back(std::move(c.polyline));
  return out;
}

double polylineLength(const Polyline3d& polyline) {
  const auto& p = polyline.points;
  double length = 0.0;
  for (std::size_t i = 1; i < p.size(); ++i) length += (p[i] - p[i - 1]).norm();
  if (polyline.closed && p.size() > 1) length += (p.front() - p.back()).norm();
  return length;
}

Polyline3d resamplePolyline(const Polyline3d& polyline, int count) {
  const int min_count = polyline.closed ? 1 : 2;
  if (count < min_count) {
    throw InvalidArgumentError("resamplePolyline: count " + std::to_string(count) + " is too small; an " +
                               (polyline.closed ? "closed" : "open") + " polyline needs at least " +
                               std::to_string(min_count) + " points");
  }
  std::vector<Eigen::Vector3d> pts = polyline.points;
  if (polyline.closed && !pts.empty()) pts.push_back(pts.front());
  std::vector<double> cumulative(pts.size(), 0.0);
  for (std::size_t i = 1; i < pts.size(); ++i) cumulative[i] = cumulative[i - 1] + (pts[i] - pts[i - 1]).norm();
  const double length = cumulative.empty() ? 0.0 : cumulative.back();
  if (!(length > 0.0) || !std::isfinite(length)) {
    throw InvalidArgumentError("resamplePolyline: the polyline has " + std::to_string(polyline.points.size()) +
                               " points and zero (or non-finite) length; nothing to resample");
  }
  Polyline3d out;
  out.closed = polyline.closed;
  out.points.reserve(static_cast<std::size_t>(count));
  const double step = polyline.closed ? length / count : length / (count - 1);
  std::size_t seg = 1;
  for (int j = 0; j < count; ++j) {
    const double s = (!polyline.closed && j == count - 1) ? length : j * step;
    while (seg + 1 < pts.size() && cumulative[seg] < s) ++seg;
    const double seg_len = cumulative[seg] - cumulative[seg - 1];
    const double t = seg_len > 0.0 ? std::clamp((s - cumulative[seg - 1]) / seg_len, 0.0, 1.0) : 0.0;
    out.points.push_back(pts[seg - 1] + t * (pts[seg] - pts[seg - 1]));
  }
  return out;
}

}  // namespace mrsns
