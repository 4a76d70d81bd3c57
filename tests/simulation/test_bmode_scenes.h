#pragma once
// Scenes for the B-mode renderer's tests: the fCal N-wire phantom in a water
// bath (the PLUS device set's wires, with the sweep and ground truth of
// tests/ultrasound/test_calibration_synthetic.cpp), a straight vessel and a
// bone plate in tissue.
#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>

#include "mrsns/io/device_set.h"
#include "mrsns/simulation/bmode_renderer.h"

namespace mrsns::test {

/// The phantom's wires (phantom frame = scene frame) in a bath that holds the
/// whole phantom and every image plane of the sweep.
inline simulation::EchoScene nwireScene(const io::PhantomDefinition& phantom) {
  simulation::EchoScene scene;
  for (const auto& pattern : phantom.patterns) {
    for (const auto& wire : pattern.wires) scene.wires.push_back({wire.end_point_front, wire.end_point_back, 0.25});
  }
  simulation::EchoBox bath;
  bath.scene_T_box.translation() = Eigen::Vector3d(35.0, 20.0, 10.0);
  bath.half_extent_mm = Eigen::Vector3d(120.0, 120.0, 120.0);
  scene.water_bath = bath;
  return scene;
}

/// fCal's image plane over the phantom (as tests/ultrasound/synthetic_fcal.h):
/// image x along -phantom x, depth along -phantom z, the top pattern's wires
/// near the transducer.
inline Eigen::Isometry3d nominalPlane(double y_mm) {
  Eigen::Isometry3d t = Eigen::Isometry3d::Identity();
  t.linear() << -1, 0, 0, 0, 0, -1, 0, -1, 0;
  t.linear().col(2) = t.linear().col(0).cross(t.linear().col(1));
  t.translation() = Eigen::Vector3d(66.4, y_mm, 31.5);
  return t;
}

/// Signed distance to a straight tube: the axis through `point` along
/// `direction` (unit), radius `radius_mm`.
inline auto tubeDistance(const Eigen::Vector3d& point, const Eigen::Vector3d& direction, double radius_mm) {
  return [point, direction, radius_mm](const Eigen::Vector3d& p) {
    const Eigen::Vector3d v = p - point;
    return (v - v.dot(direction) * direction).norm() - radius_mm;
  };
}

/// A bone plate: the half-space beyond `depth_mm` (scene y) that ends at
/// scene x = `edge_x_mm` (bone for x < edge). max() of two half-spaces is
/// 1-Lipschitz, as the renderer assumes.
inline auto plateDistance(double depth_mm, double edge_x_mm) {
  return [depth_mm, edge_x_mm](const Eigen::Vector3d& p) { return std::max(depth_mm - p.y(), p.x() - edge_x_mm); };
}

}  // namespace mrsns::test
