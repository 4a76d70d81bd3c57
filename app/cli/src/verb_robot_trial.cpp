// `mrsns-cli robot-trial`: the simulated robotic screw placement of paper 001 §III.C (C5 and C6 pedicle
// screws on the bundled cervical phantom, through calibration, registration, tracking noise, the control
// loop and its safety supervisor), with the deviations beside the paper's.
#include <sstream>

#include "cli_context.h"
#include "mrsns/core/error.h"
#include "mrsns/robot/placement_trial.h"

namespace mrsns::cli {
namespace {

Json summary(const robot::DeviationSummary& s) {
  return Json{{"mean", s.mean}, {"std", s.std}, {"max", s.max}};
}

Report run(const robot::PlacementTrialOptions& o) {
  const auto r = robot::runPlacementTrial(o);
  Report rep;
  rep.json["verb"] = "robot-trial";
  rep.json["trials"] = o.trials;
  rep.json["seed"] = o.seed;
  rep.json["placements"] = r.placements.size();
  rep.json["completed"] = r.completed;
  rep.json["noise_model"] = {{"tracking_noise_rms_mm", o.tracking_noise_mm},
                             {"tracking_rotation_deg_per_axis", o.tracking_rotation_deg},
                             {"tracker_rate_hz", o.tracker_rate_hz},
                             {"calibration", "simulated robot-tracker AX=YB calibration with the same tracker noise"},
                             {"calibration_stations", o.calibration_stations},
                             {"calibration_frames_per_station", o.calibration_frames_per_station},
                             {"registration_fle_rms_mm", o.registration_fle_mm},
                             {"soft_tissue_deformation_mm", o.deformation_amplitude_mm},
                             {"deformation_period_s", o.deformation_period_s},
                             {"advance_speed_mm_s", o.advance_speed_mm_s}};
  rep.json["distance_deviation_mm"] = summary(r.distance_deviation_mm);
  rep.json["angle_deviation_deg"] = summary(r.angle_deviation_deg);
  rep.json["tip_deviation_mm"] = summary(r.tip_deviation_mm);
  Json by_reason = Json::object();
  for (const auto& [reason, n] : r.stops) by_reason[reason] = n;
  rep.json["stops"] = {{"total", r.total_stops}, {"by_reason", by_reason}};
  rep.json["calibration"] = {{"flange_marker_error_mm", r.calibration_flange_marker_error_mm},
                             {"flange_marker_error_deg", r.calibration_flange_marker_error_deg},
                             {"residual_rms_mm", r.calibration_residual_rms_mm}};
  rep.json["registration"] = {{"fre_rms_mm", r.registration_fre_mm},
                              {"true_error_at_entries_rms_mm", r.registration_tre_at_entries_mm}};
  rep.json["paper"] = {{"distance_deviation_mm", {{"mean", 1.04}, {"std", 0.27}}},
                       {"angle_deviation_deg", {{"mean", 1.53}, {"std", 0.41}}}};
  rep.json["goal"] = {{"distance_deviation_mm", 0.8}, {"angle_deviation_deg", 1.0}};
  rep.json["goal_met"] = r.completed > 0 && r.distance_deviation_mm.mean <= 0.8 && r.angle_deviation_deg.mean <= 1.0;
  Json per = Json::array();
  for (const auto& p : r.placements) {
    per.push_back({{"trial", p.trial},
                   {"path", p.path},
                   {"completed", p.completed},
                   {"distance_deviation_mm", p.distance_deviation_mm},
                   {"angle_deviation_deg", p.angle_deviation_deg},
                   {"tip_deviation_mm", p.tip_deviation_mm},
                   {"min_soft_tissue_distance_mm", p.min_soft_tissue_distance_mm},
                   {"stops", p.stops},
                   {"duration_s", p.duration_s}});
  }
  rep.json["per_placement"] = per;
  rep.json["control_cycles"] = r.cycles;
  std::ostringstream t;
  t.precision(3);
  t << "robot-trial: " << o.trials << " trials, " << r.completed << "/" << r.placements.size() << " screws placed, "
    << r.total_stops << " stops\n"
    << "                 distance (mm)      angle (deg)\n"
    << "simulated        " << r.distance_deviation_mm.mean << " +/- " << r.distance_deviation_mm.std << "    "
    << r.angle_deviation_deg.mean << " +/- " << r.angle_deviation_deg.std << "\n"
    << "paper 001        1.04 +/- 0.27      1.53 +/- 0.41\n"
    << "goal             <= 0.8             <= 1.0\n";
  rep.text = t.str();
  return rep;
}

}  // namespace

void registerRobotTrialVerb(CLI::App& app, GlobalOptions& options, VerbList& verbs) {
  auto o = std::make_shared<robot::PlacementTrialOptions>();
  auto* sub = app.add_subcommand("robot-trial",
                                 "simulated robotic C5/C6 pedicle screw placement (paper 001 §III.C): deviations "
                                 "from the plan and the safety stops");
  sub->add_option("--trials", o->trials, "trials (each places one C5 and one C6 screw)")->capture_default_str();
  sub->add_option("--seed", o->seed, "random seed")->capture_default_str();
  sub->add_option("--tracking-noise", o->tracking_noise_mm, "tracking noise, 3D RMS (mm)")->capture_default_str();
  sub->add_option("--tracking-rotation", o->tracking_rotation_deg, "marker orientation noise per axis (deg)")
      ->capture_default_str();
  sub->add_option("--fle", o->registration_fle_mm, "registration fiducial localisation error, 3D RMS (mm)")
      ->capture_default_str();
  sub->add_option("--deformation", o->deformation_amplitude_mm, "soft-tissue deformation amplitude (mm)")
      ->capture_default_str();
  sub->add_option("--advance-speed", o->advance_speed_mm_s, "drilling advance speed (mm/s)")->capture_default_str();
  addJsonFlag(*sub, options);
  verbs.emplace_back(sub, [o] { return run(*o); });
}

}  // namespace mrsns::cli
