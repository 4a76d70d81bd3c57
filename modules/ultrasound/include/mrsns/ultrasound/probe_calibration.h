#pragma once
// The whole fCal workflow on recorded sequences: every frame segmented (in
// parallel), paired with its ProbeToReference pose, the spatial calibration
// on one sequence and its error figures on another.
#include <Eigen/Geometry>
#include <cstddef>
#include <optional>
#include <string>
#include <vector>

#include "mrsns/core/tracked_frame.h"
#include "mrsns/io/device_set.h"
#include "mrsns/ultrasound/nwire_segmentation.h"
#include "mrsns/ultrasound/spatial_calibration.h"
#include "mrsns/ultrasound/tracker_lag.h"

namespace mrsns::ultrasound {

struct FrameSegmentationReport {
  std::size_t frame_index = 0;
  SegmentationStatus status = SegmentationStatus::NoCandidates;
  bool pose_valid = false;
  std::string reason;  ///< empty when the frame was used
};

struct SequenceSegmentation {
  std::vector<CalibrationFrame> frames;          ///< segmented frames with a valid probe pose
  std::vector<FrameSegmentationReport> reports;  ///< one per frame of the sequence
  std::size_t total_frames = 0;
  std::size_t segmented_frames = 0;
  std::size_t frames_without_pose = 0;
  double seconds = 0.0;
};

/// A frame's pixels as an MF image (PLUS's image frame): MF/MFA are used
/// as stored, UF/UN/MN are flipped. Throws UnsupportedError for other
/// orientations or pixel formats than 8-bit single-component 2D frames.
std::vector<std::uint8_t> toMfPixels(const TrackedSequence& sequence, const TrackedFrame& frame);

/// Segments every frame of `sequence` and pairs it with `probe_to_reference`
/// (e.g. "ProbeToReference", computed through the frame's transforms).
/// Throws FrameError when no frame has that transform, InvalidArgumentError
/// when frames lack pixels. `threads` 0 uses the hardware concurrency.
SequenceSegmentation segmentCalibrationSequence(const TrackedSequence& sequence, const io::PhantomDefinition& phantom,
                                                const NWireSegmentationOptions& options,
                                                const std::string& probe_to_reference = "ProbeToReference",
                                                unsigned threads = 0);

/// PhantomToReference of the configuration; throws FormatError naming the
/// file when it has none (register the phantom first).
Eigen::Isometry3d phantomToReference(const io::DeviceSetConfiguration& config);

/// The wire names of a phantom, pattern by pattern.
std::vector<std::string> wireNames(const io::PhantomDefinition& phantom);

/// What the calibration sweep says about the tracker lag when another lag
/// was applied (TrackerLagOptions::check): a freehand sweep recorded with
/// an uncalibrated lag fits markedly better at that lag.
struct TrackerLagCheck {
  /// `estimate.estimated` is false when the sweep does not pin a lag down
  /// (`estimate.note` says why).
  TrackerLagEstimate estimate;
  /// Calibration 3D reprojection error (PLUS's figure, mm) on the lag
  /// curve's frames at the estimated lag and at the applied one.
  double error_at_estimate_mm = 0.0;
  double error_as_applied_mm = 0.0;
  /// The estimate lies more than a search step from the applied lag and
  /// lowers the calibration error by more than `kSignificantGain`.
  bool significant = false;
  std::string advice;  ///< what to do, when significant
  static constexpr double kSignificantGain = 0.10;
};

struct ProbeCalibrationRun {
  SpatialCalibrationResult result;
  SequenceSegmentation calibration;
  SequenceSegmentation validation;
  CalibrationErrorReport validation_errors;
  /// The validation frames the errors were computed on (paired with the
  /// probe pose at their lag-shifted time), e.g. to judge another
  /// ImageToProbe like for like.
  std::vector<CalibrationFrame> validation_paired;
  /// The lag applied to both sequences (estimated, given, or 0).
  TrackerLagEstimate tracker_lag;
  /// With TrackerLagOptions::check: the lag the calibration sweep points to.
  std::optional<TrackerLagCheck> tracker_lag_check;
  std::size_t calibration_frames_paired = 0, validation_frames_paired = 0;  ///< after the lag shift
  double seconds = 0.0;
};

/// Calibrates on `calibration` and evaluates on `validation` with the
/// phantom, segmentation parameters and PhantomToReference of `config`.
ProbeCalibrationRun calibrateProbe(const io::DeviceSetConfiguration& config, const TrackedSequence& calibration,
                                   const TrackedSequence& validation, const SpatialCalibrationOptions& options = {});

/// The same with a tracker lag: given, or estimated from the calibration
/// sequence (estimateTrackerLag), then applied to both sequences.
ProbeCalibrationRun calibrateProbe(const io::DeviceSetConfiguration& config, const TrackedSequence& calibration,
                                   const TrackedSequence& validation, const SpatialCalibrationOptions& options,
                                   const TrackerLagOptions& lag);

}  // namespace mrsns::ultrasound
