#pragma once
// N-wire phantom segmentation of one B-mode frame (PLUS fCal style): bright
// wire cross-sections are isolated by removing bar-like structures
// (reverberations, membranes) and speckle smaller than a wire with
// morphological openings, thresholded, clustered into dot candidates, then
// three collinear dots per N pattern are searched and labelled wire by wire.
#include <Eigen/Core>
#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "mrsns/io/device_set.h"

namespace mrsns::ultrasound {

/// An 8-bit grey image in MF orientation (x = marked side, y = far from the
/// transducer), row-major, x fastest. Does not own the pixels.
struct GrayImageView {
  int width = 0;
  int height = 0;
  std::span<const std::uint8_t> pixels;
};

/// The segmentation parameters, in pixels where PLUS gives mm.
struct NWireSegmentationOptions {
  double approximate_spacing_mm = 0.078;
  double opening_circle_radius_mm = 0.27;
  double opening_bar_size_mm = 2.0;
  int clip_x = 0, clip_y = 0, clip_width = 0, clip_height = 0;  ///< 0 size: whole image
  double threshold_percent = 10.0;                              ///< of (max - min) above min, after filtering
  double collinear_max_distance_mm = 0.6;
  double min_theta = -70.0 * 3.14159265358979323846 / 180.0;  ///< line angle from the image x axis, rad
  double max_theta = 70.0 * 3.14159265358979323846 / 180.0;
  double max_angle_difference = 10.0 * 3.14159265358979323846 / 180.0;  ///< between the lines of one frame, rad
  double max_line_pair_distance_error_percent = 10.0;
  /// How far the true pixel spacing may be from the approximate one (%),
  /// added to the tolerance of the absolute line-pair distances.
  double spacing_uncertainty_percent = 10.0;
  int max_candidates = 20;  ///< brightest dot candidates kept
  /// Maximum ratio of a line's length (outer dots) to the outer wires'
  /// distance: bounds the plane's obliquity to the wires (1.6 ~ 51 deg).
  double max_line_length_ratio = 1.6;
};

/// Options from a device set's Segmentation element (absent attributes keep
/// their defaults).
NWireSegmentationOptions segmentationOptionsFrom(const io::SegmentationParameters& parameters);

enum class SegmentationStatus { Ok, NoCandidates, TooFewCandidates, NoPattern };
std::string segmentationStatusName(SegmentationStatus status);

struct DotCandidate {
  Eigen::Vector2d position_px = Eigen::Vector2d::Zero();  ///< centroid weighted by the filtered intensities (as PLUS)
  double intensity = 0.0;                                 ///< sum of filtered intensities / 255 (the ranking score)
  int area_px = 0;
};

/// The result for one frame: `wire_points_px` holds one point per phantom
/// wire (pattern by pattern, in definition order) when status is Ok.
struct NWireSegmentation {
  SegmentationStatus status = SegmentationStatus::NoCandidates;
  std::string reason;  ///< why the frame was rejected (empty when Ok)
  std::vector<DotCandidate> candidates;
  std::vector<Eigen::Vector2d> wire_points_px;
  double pattern_intensity = 0.0;

  [[nodiscard]] bool ok() const { return status == SegmentationStatus::Ok; }
};

/// Segments one frame. Throws InvalidArgumentError when the view does not
/// match its size, or the phantom has patterns other than 3-wire NWires.
NWireSegmentation segmentNWires(const GrayImageView& image, const io::PhantomDefinition& phantom,
                                const NWireSegmentationOptions& options);

}  // namespace mrsns::ultrasound
