#pragma once
// PLUS device-set configuration files (PlusDeviceSet_*.xml): the phantom
// definition (N-wire patterns and landmarks), the fixed coordinate
// definitions and the wire-segmentation parameters, as typed values.
#include <Eigen/Core>
#include <array>
#include <filesystem>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace mrsns::io {

/// One wire of a phantom, both end points in the phantom frame (mm).
struct PhantomWire {
  std::string name;  ///< e.g. "1:E2_e2"
  Eigen::Vector3d end_point_front = Eigen::Vector3d::Zero();
  Eigen::Vector3d end_point_back = Eigen::Vector3d::Zero();
};

/// A wire pattern, e.g. an N made of three wires (Type "NWire").
struct PhantomPattern {
  std::string type;
  std::vector<PhantomWire> wires;
};

struct PhantomLandmark {
  std::string name;
  Eigen::Vector3d position_phantom = Eigen::Vector3d::Zero();  ///< mm, phantom frame
};

struct PhantomDefinition {
  std::string name;  ///< Description/@Name, e.g. "fCAL"
  std::string type;  ///< Description/@Type, e.g. "Multi-N"
  std::string version;
  std::string wiring_version;
  std::string institution;
  std::vector<PhantomPattern> patterns;
  std::vector<PhantomLandmark> landmarks;

  [[nodiscard]] std::size_t wireCount() const {
    std::size_t n = 0;
    for (const auto& p : patterns) n += p.wires.size();
    return n;
  }
};

/// A fixed transform of CoordinateDefinitions: `to_T_from` maps points from
/// frame `from` to frame `to` (PLUS "FromToTo").
struct CoordinateDefinition {
  std::string from;
  std::string to;
  Eigen::Matrix4d to_T_from = Eigen::Matrix4d::Identity();
  std::optional<double> error;  ///< the calibration error PLUS stored, mm
  std::string date;

  [[nodiscard]] std::string name() const { return from + "To" + to; }
};

/// Parameters of PLUS's N-wire segmentation (the Segmentation element).
/// Angles are converted to radians; every attribute is also kept verbatim.
struct SegmentationParameters {
  std::optional<double> approximate_spacing_mm_per_pixel;
  std::optional<double> morphological_opening_circle_radius_mm;
  std::optional<double> morphological_opening_bar_size_mm;
  std::optional<double> max_line_pair_distance_error_percent;
  std::optional<double> angle_tolerance;       ///< radians (AngleToleranceDegrees)
  std::optional<double> max_angle_difference;  ///< radians (MaxAngleDifferenceDegrees)
  std::optional<double> min_theta;             ///< radians (MinThetaDegrees)
  std::optional<double> max_theta;             ///< radians (MaxThetaDegrees)
  std::optional<double> max_line_shift_mm;
  std::optional<double> threshold_image_percent;
  std::optional<double> collinear_points_max_distance_from_line_mm;
  std::optional<std::array<int, 2>> clip_rectangle_origin_px;
  std::optional<std::array<int, 2>> clip_rectangle_size_px;
  std::optional<bool> use_original_image_intensity_for_dot_intensity_score;
  std::optional<int> number_of_maximum_fiducial_point_candidates;
  std::vector<std::pair<std::string, std::string>> attributes;  ///< every attribute, in file order

  /// The verbatim value of attribute `name`, if present.
  [[nodiscard]] std::optional<std::string> attribute(std::string_view name) const {
    for (const auto& [key, value] : attributes) {
      if (key == name) return value;
    }
    return std::nullopt;
  }
};

struct DeviceSetConfiguration {
  std::string source;       ///< the file it came from (for messages)
  std::string name;         ///< DeviceSet/@Name
  std::string description;  ///< DeviceSet/@Description
  std::optional<PhantomDefinition> phantom;
  std::vector<CoordinateDefinition> coordinate_definitions;
  std::optional<SegmentationParameters> segmentation;

  /// The phantom definition; throws FormatError naming the file when absent.
  [[nodiscard]] const PhantomDefinition& requirePhantom() const;
  /// The coordinate definition from -> to, if the file has it.
  [[nodiscard]] std::optional<CoordinateDefinition> findTransform(std::string_view from, std::string_view to) const;
};

/// Parses a device-set file. Throws FileError (unreadable), FormatError
/// (malformed XML, not a PlusConfiguration, bad numbers; the message names the
/// element and attribute).
DeviceSetConfiguration readDeviceSet(const std::filesystem::path& path);
/// The same from XML text; `source` names it in messages.
DeviceSetConfiguration parseDeviceSet(std::string_view xml, const std::string& source);

}  // namespace mrsns::io
