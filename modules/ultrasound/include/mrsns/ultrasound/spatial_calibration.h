#pragma once
// Probe spatial calibration from N-wire phantom frames: ImageToProbe
// (rotation, translation and the pixel spacing of both image axes) by least
// squares over every frame, with iterative outlier rejection, and the error
// figures PLUS's fCal reports (3D reprojection error of the middle-wire
// points, 2D wire reprojection per wire).
#include <Eigen/Geometry>
#include <cstddef>
#include <string>
#include <vector>

#include "mrsns/ultrasound/nwire_geometry.h"

namespace mrsns::ultrasound {

/// One segmented frame: the dots of every wire (3 per pattern, in the
/// phantom's wire order, MF image pixels) and the probe pose at that time.
struct CalibrationFrame {
  std::size_t frame_index = 0;
  std::vector<Eigen::Vector2d> wire_points_px;
  Eigen::Isometry3d reference_T_probe = Eigen::Isometry3d::Identity();  ///< ProbeToReference
};

enum class CalibrationObjective {
  MiddleWirePoints,  ///< |ImageToProbe * dot - middle-wire point|, PLUS's linear formulation
  DistanceToWires,   ///< distance of every mapped dot (9 per frame) from its wire
  Both,              ///< the two residual sets together
};

struct SpatialCalibrationOptions {
  /// Both residual sets by default: PLUS's middle-wire points pin the
  /// elevation through the N ratio, the distances of all dots to their
  /// wires constrain the plane without amplifying the dots' error through
  /// that ratio (on PLUS's fCal recording: validation 1.19 mm, against 1.25
  /// for middle-wire points alone and PLUS's 1.25; doc/README.md).
  CalibrationObjective objective = CalibrationObjective::Both;
  std::size_t min_frames = 10;
  /// The middle-wire points must span the image plane: second principal RMS
  /// extent in the probe frame, mm.
  double min_point_spread_mm = 2.0;
  /// RMS spread of the probe positions in the phantom frame, mm.
  double min_probe_motion_mm = 2.0;
  /// A frame whose error exceeds mean + factor * std is dropped, refit, repeated.
  double outlier_factor = 3.0;
  int max_outlier_iterations = 10;
};

/// 2D reprojection of one wire: segmented dot minus where the wire crosses
/// the image plane (px), and the distance in mm.
struct WireReprojection {
  std::string wire_name;
  Eigen::Vector2d mean_px = Eigen::Vector2d::Zero();
  Eigen::Vector2d std_px = Eigen::Vector2d::Zero();
  double mean_distance_mm = 0.0;
  std::size_t count = 0;
};

struct CalibrationErrorReport {
  /// 3D reprojection error of the middle-wire points (mm) over every
  /// (frame, pattern), as PLUS reports it: errors above mean + 2 std are
  /// left out, repeatedly, until none is (PLUS's published figures are
  /// these), and per frame (mean of patterns, nothing left out).
  double reprojection_3d_mean_mm = 0.0;
  double reprojection_3d_std_mm = 0.0;
  std::size_t reprojection_3d_count = 0;     ///< errors kept
  double reprojection_3d_all_mean_mm = 0.0;  ///< over every error, none left out
  double reprojection_3d_all_std_mm = 0.0;
  std::vector<double> reprojection_3d_per_frame_mm;
  /// RMS distance of every dot (mapped to the phantom) from its wire, mm.
  double wire_distance_rms_mm = 0.0;
  std::vector<WireReprojection> wires;
  std::size_t frames = 0;
};

struct SpatialCalibrationResult {
  /// PLUS's ImageToProbe: columns x, y scaled by the pixel spacing, z the
  /// unit normal scaled by their mean, then the translation (mm).
  Eigen::Matrix4d probe_T_image = Eigen::Matrix4d::Identity();
  Eigen::Matrix3d rotation = Eigen::Matrix3d::Identity();
  Eigen::Vector3d translation_mm = Eigen::Vector3d::Zero();
  Eigen::Vector2d pixel_spacing_mm = Eigen::Vector2d::Zero();
  std::size_t frames_used = 0;
  std::vector<std::size_t> rejected_frames;  ///< frame_index of the outliers
  int iterations = 0;
  CalibrationErrorReport calibration;  ///< on the frames used
};

/// Calibrates from `frames`, with the phantom pose `reference_T_phantom`
/// (PhantomToReference). Throws ComputationError for too few frames or too
/// little probe motion (the message says what was found and what is needed).
SpatialCalibrationResult calibrateSpatial(const std::vector<CalibrationFrame>& frames,
                                          const std::vector<NWirePattern>& patterns,
                                          const Eigen::Isometry3d& reference_T_phantom,
                                          const SpatialCalibrationOptions& options = {});

/// The error figures of `probe_T_image` on `frames` (e.g. a validation set).
CalibrationErrorReport evaluateSpatialCalibration(const Eigen::Matrix4d& probe_T_image,
                                                  const std::vector<CalibrationFrame>& frames,
                                                  const std::vector<NWirePattern>& patterns,
                                                  const Eigen::Isometry3d& reference_T_phantom,
                                                  const std::vector<std::string>& wire_names = {});

/// The full ImageToProbe from a rotation, translation and the x/y spacing.
Eigen::Matrix4d imageToProbeMatrix(const Eigen::Matrix3d& rotation, const Eigen::Vector3d& translation_mm,
                                   const Eigen::Vector2d& pixel_spacing_mm);

}  // namespace mrsns::ultrasound
