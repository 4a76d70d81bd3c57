#include "mrsns/ultrasound/nwire_geometry.h"

#include <Eigen/Geometry>

#include "mrsns/core/error.h"

namespace mrsns::ultrasound {

std::vector<NWirePattern> nwireGeometry(const io::PhantomDefinition& phantom) {
  if (phantom.patterns.empty()) {
    throw InvalidArgumentError("phantom definition '" + phantom.name +
                               "' has no wire pattern: N-wire calibration needs NWire patterns in its Geometry");
  }
  std::vector<NWirePattern> patterns;
  for (std::size_t p = 0; p < phantom.patterns.size(); ++p) {
    const auto& src = phantom.patterns[p];
    if (src.type != "NWire" || src.wires.size() != 3) {
      throw FormatError("phantom pattern " + std::to_string(p + 1) + " is '" + src.type + "' with " +
                        std::to_string(src.wires.size()) + " wires: only NWire patterns of 3 wires are supported");
    }
    NWirePattern g;
    for (int w = 0; w < 3; ++w) {
      const Eigen::Vector3d d = src.wires[w].end_point_back - src.wires[w].end_point_front;
      if (d.norm() < 1e-6) throw FormatError("phantom wire '" + src.wires[w].name + "' has coincident end points");
      g.front[w] = src.wires[w].end_point_front;
      g.direction[w] = d.normalized();
    }
    if (g.direction[0].cross(g.direction[2]).norm() > 1e-3) {
      throw FormatError("phantom pattern " + std::to_string(p + 1) + ": the outer wires are not parallel");
    }
    g.outer_distance_mm = (g.front[2] - g.front[0]).cross(g.direction[0]).norm();
    if (g.outer_distance_mm < 1e-3)
      throw FormatError("phantom pattern " + std::to_string(p + 1) + ": outer wires coincide");
    if (!patterns.empty()) {
      const auto& prev = patterns.back();
      const Eigen::Vector3d normal = prev.direction[0].cross(prev.direction[1]).normalized();
      g.distance_to_previous_mm = std::abs(normal.dot(g.front[0] - prev.front[0]));
    }
    patterns.push_back(g);
  }
  return patterns;
}

Eigen::Vector3d middleWirePoint(const NWirePattern& pattern, const Eigen::Vector2d& p1, const Eigen::Vector2d& p2,
                                const Eigen::Vector2d& p3) {
  // Signed ratio: the projection of p2 on the line p1 p3 (it also absorbs
  // the dot's small offset across the line).
  const double total_sq = (p3 - p1).squaredNorm();
  const double alpha = total_sq > 0.0 ? (p2 - p1).dot(p3 - p1) / total_sq : 0.5;
  // Across-wire axis of the N's plane: from outer wire 1 to outer wire 3,
  // perpendicular to them. Every point of the image line between the outer
  // dots has across-coordinate alpha * outer distance.
  const Eigen::Vector3d d = pattern.direction[0];
  Eigen::Vector3d across = pattern.front[2] - pattern.front[0];
  across -= d * d.dot(across);
  const double width = across.norm();
  across /= width;
  const double target = alpha * width;
  const double start = across.dot(pattern.front[1] - pattern.front[0]);
  const double rate = across.dot(pattern.direction[1]);
  const double s = (target - start) / rate;
  return pattern.front[1] + s * pattern.direction[1];
}

double distanceToWire(const NWirePattern& pattern, int w, const Eigen::Vector3d& p) {
  return (p - pattern.front[w]).cross(pattern.direction[w]).norm();
}

}  // namespace mrsns::ultrasound
