#pragma once
// A synthetic fCal-like N-wire phantom (three N patterns), the ground truth
// of a simulated calibration, and the nominal image plane through it: shared
// by the synthetic calibration and tracker-lag tests.
#include <Eigen/Geometry>
#include <string>

#include "mrsns/io/device_set.h"

namespace mrsns::test {

inline io::PhantomDefinition fcalPhantom() {
  io::PhantomDefinition p;
  p.name = "fCAL";
  const double z[3] = {10.0, 5.0, 0.0};
  const double middle_front[3] = {40.0, 25.0, 45.0}, middle_back[3] = {25.0, 45.0, 25.0};
  const double outer3[3] = {45.0, 50.0, 50.0};
  for (int k = 0; k < 3; ++k) {
    io::PhantomPattern pattern;
    pattern.type = "NWire";
    pattern.wires.push_back({"w" + std::to_string(3 * k + 1), {20, 0, z[k]}, {20, 40, z[k]}});
    pattern.wires.push_back({"w" + std::to_string(3 * k + 2), {middle_front[k], 0, z[k]}, {middle_back[k], 40, z[k]}});
    pattern.wires.push_back({"w" + std::to_string(3 * k + 3), {outer3[k], 0, z[k]}, {outer3[k], 40, z[k]}});
    p.patterns.push_back(pattern);
  }
  return p;
}

struct Truth {
  Eigen::Isometry3d probe_T_image_rigid = Eigen::Isometry3d::Identity();
  Eigen::Vector2d spacing{0.080, 0.074};
  Eigen::Isometry3d reference_T_phantom = Eigen::Isometry3d::Identity();
};

// Image x along -phantom x, image y (depth) along -phantom z: the wires of
// the top pattern appear near the transducer, wire 1 on the right.
inline Eigen::Isometry3d nominalPlane(double y_mm) {
  Eigen::Isometry3d t = Eigen::Isometry3d::Identity();
  t.linear() << -1, 0, 0, 0, 0, -1, 0, -1, 0;
  t.linear().col(2) = t.linear().col(0).cross(t.linear().col(1));
  t.translation() = Eigen::Vector3d(66.4, y_mm, 31.5);
  return t;
}

}  // namespace mrsns::test
