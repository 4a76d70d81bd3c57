#pragma once
// Planning primitives: a planned screw path (entry, target, diameter, length)
// and its clearance to a surface (e.g. soft tissue, a vessel, the spinal
// canal) along its length. Stored as Slicer markups lines (see
// mrsns/io/screw_path_io.h); the description string carries the
// vertebra, diameter and length.
#include <Eigen/Core>
#include <string>
#include <vector>

#include "mrsns/core/mesh_locator.h"

namespace mrsns::registration {

struct ScrewPath {
  std::string name;                                  ///< e.g. "C5 left"
  std::string vertebra;                              ///< e.g. "C5"; may be empty
  Eigen::Vector3d entry = Eigen::Vector3d::Zero();   ///< LPS mm, where the screw enters the bone
  Eigen::Vector3d target = Eigen::Vector3d::Zero();  ///< LPS mm, the planned tip direction/end
  double diameter_mm = 3.5;
  /// Screw length from the entry (mm); <= 0 means |target - entry|.
  double length_mm = 0.0;

  /// Unit vector entry -> target. Throws InvalidArgumentError when entry == target or NaN.
  [[nodiscard]] Eigen::Vector3d direction() const;
  /// length_mm when > 0, else |target - entry|.
  [[nodiscard]] double effectiveLength() const;
  /// entry + effectiveLength() * direction().
  [[nodiscard]] Eigen::Vector3d tip() const;
};

/// Throws InvalidArgumentError naming the path when it is unusable (NaN,
/// entry == target, diameter <= 0).
void validateScrewPath(const ScrewPath& path);

struct ClearanceSample {
  double depth_mm = 0.0;  ///< distance from the entry along the axis
  Eigen::Vector3d axis_point = Eigen::Vector3d::Zero();
  Eigen::Vector3d surface_point = Eigen::Vector3d::Zero();  ///< closest surface point
  /// Distance from the axis point to the surface minus the screw radius (mm);
  /// negative: the screw cuts the surface.
  double clearance_mm = 0.0;
};

struct ClearanceOptions {
  double step_mm = 1.0;  ///< profile sampling step along the axis
};

struct PathClearance {
  double min_clearance_mm = 0.0;  ///< smallest clearance along the screw (negative: cuts)
  double min_depth_mm = 0.0;      ///< where, from the entry
  Eigen::Vector3d min_axis_point = Eigen::Vector3d::Zero();
  Eigen::Vector3d min_surface_point = Eigen::Vector3d::Zero();
  /// Depths (mm) where the screw axis crosses the surface.
  std::vector<double> crossings_mm;
  bool cuts_surface = false;  ///< min_clearance_mm < 0
  /// Samples every step_mm from the entry, plus the tip.
  std::vector<ClearanceSample> profile;
};

/// Clearance of the screw (a cylinder of the screw radius along the axis
/// from the entry over its length) to `surface`. Between samples the minimum
/// is refined by golden-section search, and axis crossings give exactly
/// -radius. Throws as validateScrewPath and for step_mm <= 0.
PathClearance screwPathClearance(const ScrewPath& path, const MeshLocator& surface,
                                 const ClearanceOptions& options = {});

/// "vertebra=C5; diameter_mm=3.5; length_mm=40" (the markups line description).
std::string screwPathDescription(const ScrewPath& path);

/// A path from a markups line: name, its two control points and a
/// description as written by screwPathDescription (missing keys keep their
/// defaults; unknown keys are ignored). Throws InvalidArgumentError naming
/// the path when a value does not parse.
ScrewPath screwPathFromLine(const std::string& name, const Eigen::Vector3d& entry, const Eigen::Vector3d& target,
                            const std::string& description);

}  // namespace mrsns::registration
