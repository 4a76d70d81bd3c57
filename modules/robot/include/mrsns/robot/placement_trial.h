#pragma once
// The simulated screw-placement trial of paper 001 §III.C: C5 and C6 pedicle screw paths planned on the
// bundled cervical phantom, placed by the simulated UR5 through the whole workstation chain (robot-tracker
// calibration from a simulated calibration run, landmark registration, tracking at 60 Hz with noise, the
// control loop and its safety supervisor against a deforming soft-tissue surface). Reports the distance
// and angle deviation of the achieved drill paths from the plan, and every stop that happened.
//
// Deviation definitions (as in post-operative CT evaluations of placed screws): the achieved path is the
// line fitted to the true drill tip positions while it advanced past the entry; distance deviation is the
// distance from the planned entry point to that line (the entry-point offset across the path), angle
// deviation the angle between the line and the planned direction. The tip deviation (the deepest achieved
// tip to the planned tip) is reported too.
#include <cstdint>
#include <map>
#include <string>
#include <vector>

namespace mrsns::robot {

struct PlacementTrialOptions {
  int trials = 5;  ///< each trial places one C5 and one C6 screw (sides alternate between trials)
  std::uint64_t seed = 1;
  // Noise model.
  double tracking_noise_mm = 0.35;          ///< marker position, 3D RMS per tracker frame (isotropic Gaussian)
  double tracking_rotation_deg = 0.15;      ///< marker orientation, RMS per axis per tracker frame
  double tracker_rate_hz = 60.0;            ///< new tracker frames; the loop runs at 500 Hz between them
  int calibration_stations = 12;            ///< robot-tracker calibration stations
  int calibration_frames_per_station = 20;  ///< frames averaged at each (static) station
  double registration_fle_mm = 0.35;        ///< fiducial localisation error, 3D RMS, of the landmark registration
  double deformation_amplitude_mm = 1.5;    ///< soft-tissue (vessel) wall displacement amplitude
  double deformation_period_s = 4.0;
  double deformation_update_s = 0.1;  ///< how often a new posterior shape reaches the supervisor
  // Procedure.
  /// Low-pass of the tracker-measured drill pose the supervisor checks (ControlLoopOptions).
  double measurement_filter_s = 0.1;
  double advance_speed_mm_s = 5.0;
  double phantom_spacing_mm = 2.0;  ///< the phantom's CT is not used here: coarse is enough for its geometry
};

struct DeviationSummary {
  double mean = 0, std = 0, max = 0;
};

struct PlacementResult {
  int trial = 0;
  std::string path;  ///< e.g. "C5 left"
  bool completed = false;
  double distance_deviation_mm = 0;
  double angle_deviation_deg = 0;
  double tip_deviation_mm = 0;
  double min_soft_tissue_distance_mm = 0;
  int stops = 0;
  double duration_s = 0;
};

struct PlacementTrialResult {
  std::vector<PlacementResult> placements;
  DeviationSummary distance_deviation_mm, angle_deviation_deg, tip_deviation_mm;
  int completed = 0;
  /// Stops by reason (supervisor StopReason names), over all placements.
  std::map<std::string, int> stops;
  int total_stops = 0;
  // What the simulated calibration and registration achieved (true errors, so the noise model's effect on
  // each link of the chain can be read).
  double calibration_flange_marker_error_mm = 0, calibration_flange_marker_error_deg = 0;
  double calibration_residual_rms_mm = 0;
  double registration_fre_mm = 0;
  double registration_tre_at_entries_mm = 0;  ///< RMS true error of the registration at the planned entries
  std::uint64_t cycles = 0;
};

/// Throws InvalidArgumentError for trials < 1 or a negative noise figure.
PlacementTrialResult runPlacementTrial(const PlacementTrialOptions& options = {});

}  // namespace mrsns::robot
