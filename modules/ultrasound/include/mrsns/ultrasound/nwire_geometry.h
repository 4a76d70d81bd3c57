#pragma once
// The geometry of an N-wire phantom that calibration needs: each N's two
// parallel outer wires and its diagonal middle wire, and where the image
// plane crosses the middle wire, found from the dots' spacing in the image.
#include <Eigen/Core>
#include <array>
#include <vector>

#include "mrsns/io/device_set.h"

namespace mrsns::ultrasound {

struct NWirePattern {
  std::array<Eigen::Vector3d, 3> front;      ///< wire front end points, phantom frame (mm)
  std::array<Eigen::Vector3d, 3> direction;  ///< unit directions front -> back
  double outer_distance_mm = 0.0;            ///< between the two parallel outer wires
  double distance_to_previous_mm = 0.0;      ///< between this pattern's plane and the previous one's (0 for the first)
};

/// The patterns of `phantom`. Throws FormatError unless every pattern is an
/// NWire of three wires with parallel, distinct outer wires, and
/// InvalidArgumentError when the phantom has no pattern.
std::vector<NWirePattern> nwireGeometry(const io::PhantomDefinition& phantom);

/// The point (phantom frame) where the image plane crosses the middle wire,
/// given the image positions of the three dots (outer, middle, outer in wire
/// order). The ratio |p1 p2| / |p1 p3| is preserved by the affine map from
/// phantom to image, and along the N's plane the outer wires sit at fixed
/// positions across their direction, which fixes the point on the middle wire.
Eigen::Vector3d middleWirePoint(const NWirePattern& pattern, const Eigen::Vector2d& p1, const Eigen::Vector2d& p2,
                                const Eigen::Vector2d& p3);

/// Distance (mm) of point `p` (phantom frame) from wire `w` of `pattern`.
double distanceToWire(const NWirePattern& pattern, int w, const Eigen::Vector3d& p);

}  // namespace mrsns::ultrasound
