// Figures of the HMD and robot module trials, as JSON for the session and the
// trial report. The noise models are copied from the options the trials ran
// with, so the report never states a model other than the one simulated.
#include "module_trials.h"

#include <algorithm>

#include "mrsns/hmd/checkerboard_trial.h"
#include "mrsns/hmd/cube_trial.h"
#include "mrsns/robot/placement_trial.h"

namespace mrsns::workflow::detail {

namespace {

constexpr double kRadToDeg = 180.0 / 3.14159265358979323846;

Json method(const hmd::MethodResult& m) {
  return {{"name", m.name},
          {"mean_rms_mm", m.mean_rms_mm},
          {"std_rms_mm", m.std_rms_mm},
          {"rms_mm", m.rms_mm},
          {"mean_abs_axis_error_mm",
           {m.mean_abs_axis_error_mm.x(), m.mean_abs_axis_error_mm.y(), m.mean_abs_axis_error_mm.z()}}};
}

Json deviation(const robot::DeviationSummary& d) {
  return {{"mean", d.mean}, {"sd", d.std}, {"max", d.max}};
}

}  // namespace

Json cubeTrialFigures(int trials, std::uint64_t seed) {
  hmd::CubeTrialOptions options;
  options.trials = trials;
  options.seed = seed;
  const auto r = hmd::runCubeTrial(options);
  const auto& n = r.options.noise;
  return {{"trials", trials},
          {"compensated", method(r.compensated)},
          {"uncompensated", method(r.uncompensated)},
          {"pointer", method(r.pointer)},
          {"front_only_compensated", method(r.front_only_compensated)},
          {"improvement_vs_uncompensated_percent", r.improvement_vs_uncompensated_percent},
          {"improvement_vs_pointer_percent", r.improvement_vs_pointer_percent},
          {"mean_view_spread_deg", r.mean_view_spread_deg},
          {"mean_view_spread_mm", r.mean_view_spread_mm},
          {"mean_dropped_fraction", r.mean_dropped_fraction},
          {"noise_model",
           {{"tremor_amplitude_mm", n.tremor_amplitude_mm},
            {"tremor_hz", {n.tremor_min_hz, n.tremor_max_hz}},
            {"tremor_rotation_deg", n.tremor_rotation_deg},
            {"drift_mm_per_s", n.drift_mm_per_s},
            {"jerk_probability", n.jerk_probability},
            {"jerk_mm", {n.jerk_min_mm, n.jerk_max_mm}},
            {"depth_bias_mm", n.depth_bias_mm},
            {"depth_error_mm", n.depth_error_mm},
            {"lateral_error_mm", n.lateral_error_mm},
            {"alignment_rotation_deg", n.alignment_rotation_deg},
            {"slam_jitter_mm", n.slam_jitter_mm},
            {"tracking_mm", n.tracking_mm},
            {"sample_rate_hz", n.sample_rate_hz},
            {"hold_s", n.hold_s},
            {"pointer_depth_error_mm", n.pointer_depth_error_mm},
            {"pointer_lateral_error_mm", n.pointer_lateral_error_mm},
            {"pointer_tip_error_mm", n.pointer_tip_error_mm}}},
          // Paper 001 Fig. 7: compensated 1.64 +/- 0.48 mm, 12.3 % better than
          // uncompensated, 32.5 % better than the pointer method.
          {"paper",
           {{"compensated_rms_mm", {{"mean", 1.64}, {"sd", 0.48}}},
            {"improvement_vs_uncompensated_percent", 12.3},
            {"improvement_vs_pointer_percent", 32.5}}}};
}

Json checkerboardTrialFigures(int poses, std::uint64_t seed) {
  hmd::CheckerboardTrialOptions options;
  options.poses = poses;
  options.seed = static_cast<unsigned>(seed);
  const auto r = hmd::runCheckerboardTrial(options);
  const auto [lo, hi] = std::minmax_element(r.distances_mm.begin(), r.distances_mm.end());
  const auto& o = r.options;
  return {{"poses", poses},
          {"rpee_mean_mm", r.rpee.mean_mm},
          {"rpee_std_mm", r.rpee.std_mm},
          {"rpee_rms_mm", r.rpee.rms_mm},
          {"rpee_mean_px", r.rpee.mean_px},
          {"rpee_std_px", r.rpee.std_px},
          {"hand_eye_rotation_error_deg", r.rotation_error_deg},
          {"hand_eye_translation_error_mm", r.translation_error_mm},
          {"per_view_rotation_rms_deg", r.hand_eye.rotation_rms_rad * kRadToDeg},
          {"per_view_translation_rms_mm", r.hand_eye.translation_rms_mm},
          {"camera_reprojection_rms_px", r.camera.rms_reprojection_px},
          {"pointer_pivot_rms_mm", r.pointer_pivot_rms_mm},
          {"pointer_tip_error_mm", r.pointer_tip_error_mm},
          {"grid_error_mm", r.grid_error_mm},
          {"distance_mm", {r.distances_mm.empty() ? 0.0 : *lo, r.distances_mm.empty() ? 0.0 : *hi}},
          {"noise_model",
           {{"tracker_position_rms_mm", o.tracker_position_rms_mm},
            {"tracker_rotation_rms_deg", o.tracker_rotation_rms_deg},
            {"tracker_samples_per_image", o.tracker_samples_per_image},
            {"digitisation_rms_mm", o.digitisation_rms_mm},
            {"camera_distance_mm", {o.min_distance_mm, o.max_distance_mm}},
            {"image", "0.7 px blur, 2 grey levels noise, 1280x720, f 1000 px, k1 -0.05, k2 0.02"}}},
          // Paper 000: retro-projection error 3.2 +/- 1.6 mm over 150 patterns.
          {"paper", {{"rpee_mm", {{"mean", 3.2}, {"sd", 1.6}}}}}};
}

Json placementTrialFigures(int trials, std::uint64_t seed) {
  robot::PlacementTrialOptions options;
  options.trials = trials;
  options.seed = seed;
  const auto r = robot::runPlacementTrial(options);
  Json placements = Json::array();
  for (const auto& p : r.placements) {
    placements.push_back({{"trial", p.trial},
                          {"path", p.path},
                          {"completed", p.completed},
                          {"distance_deviation_mm", p.distance_deviation_mm},
                          {"angle_deviation_deg", p.angle_deviation_deg},
                          {"tip_deviation_mm", p.tip_deviation_mm},
                          {"min_soft_tissue_distance_mm", p.min_soft_tissue_distance_mm},
                          {"stops", p.stops},
                          {"duration_s", p.duration_s}});
  }
  return {{"trials", trials},
          {"placements", placements},
          {"completed", r.completed},
          {"distance_deviation_mm", deviation(r.distance_deviation_mm)},
          {"angle_deviation_deg", deviation(r.angle_deviation_deg)},
          {"tip_deviation_mm", deviation(r.tip_deviation_mm)},
          {"total_stops", r.total_stops},
          {"stops", r.stops},
          {"calibration_flange_marker_error_mm", r.calibration_flange_marker_error_mm},
          {"calibration_flange_marker_error_deg", r.calibration_flange_marker_error_deg},
          {"calibration_residual_rms_mm", r.calibration_residual_rms_mm},
          {"registration_fre_mm", r.registration_fre_mm},
          {"registration_tre_at_entries_mm", r.registration_tre_at_entries_mm},
          {"control_cycles", r.cycles},
          {"noise_model",
           {{"tracking_noise_mm", options.tracking_noise_mm},
            {"tracking_rotation_deg", options.tracking_rotation_deg},
            {"tracker_rate_hz", options.tracker_rate_hz},
            {"calibration_stations", options.calibration_stations},
            {"calibration_frames_per_station", options.calibration_frames_per_station},
            {"registration_fle_mm", options.registration_fle_mm},
            {"deformation_amplitude_mm", options.deformation_amplitude_mm},
            {"deformation_period_s", options.deformation_period_s}}},
          // Paper 001 §IV: C5/C6 pedicle screws on the phantom.
          {"paper",
           {{"distance_deviation_mm", {{"mean", 1.04}, {"sd", 0.27}}},
            {"angle_deviation_deg", {{"mean", 1.53}, {"sd", 0.41}}}}}};
}

}  // namespace mrsns::workflow::detail
