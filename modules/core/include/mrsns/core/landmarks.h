#pragma once
// Named points (fiducials, anatomical landmarks) in one frame. Positions are
// always LPS millimetres inside MR-SNS: readers of RAS files convert them.
#include <Eigen/Core>
#include <string>
#include <vector>

namespace mrsns {

struct Landmark {
  std::string label;
  Eigen::Vector3d position = Eigen::Vector3d::Zero();  ///< LPS, mm
  bool selected = true;
  bool visible = true;
  bool locked = false;
  std::string description;
};

/// An ordered list of landmarks. `frame` names the coordinate frame of the
/// positions (e.g. "CT", "Reference"), empty when unknown.
struct LandmarkSet {
  std::string name;
  std::string frame;
  std::vector<Landmark> points;

  [[nodiscard]] std::size_t size() const { return points.size(); }
  [[nodiscard]] bool empty() const { return points.empty(); }
};

}  // namespace mrsns
