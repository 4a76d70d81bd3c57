// Robot calibration and HMD calibration steps with the robot and the HMD
// simulated in-process (seeded), through the same chain of transforms the
// real devices use.
#include <sstream>

#include "module_trials.h"
#include "mrsns/registration/paired_point.h"
#include "simulation.h"
#include "step_internal.h"
#ifdef MRSNS_WITH_HMD
#include "mrsns/hmd/cube_calibration.h"
#endif

namespace mrsns::workflow::detail {

namespace {

// The simulated tracker's patient reference marker (see devices.cpp).
Eigen::Isometry3d trackerTPatient() {
  Eigen::Isometry3d t = Eigen::Isometry3d::Identity();
  t.translation() = Eigen::Vector3d(0.0, 0.0, -1000.0);
  return t;
}

}  // namespace

StepResult runRobotCalibration(Session& session, const Json& params, const StepContext& context) {
  // source=ur: the stations driven on a UR controller and seen by the session's tracker; a UR port named in
  // the parameters means that too. Otherwise the in-process simulated robot and tracker below.
  std::string source = "simulated";
  for (const char* key : {"ur_host", "ur_rtde_port", "ur_script_port", "ur_dashboard_port"}) {
    if (params.is_object() && params.contains(key)) source = "ur";
  }
  if (params.is_object() && params.contains("source") && params["source"].is_string()) {
    source = params["source"].get<std::string>();
  }
  if (source == "ur") return runLiveRobotCalibration(session, params, context);
  if (source != "simulated") {
    throw InvalidArgumentError("robot-calibration: source must be ur (drive a UR controller) or simulated, not '" +
                               source + "'");
  }
  const Params p("robot-calibration", params,
                 {"source", "seed", "poses", "tracker_noise_mm", "robot_repeatability_mm"});
  const auto seed = static_cast<std::uint64_t>(p.integer("seed", 1));
  const int poses = p.integer("poses", 12);
  const double tracker_noise = p.number("tracker_noise_mm", 0.25);
  const double robot_noise = p.number("robot_repeatability_mm", 0.1);  // UR5: +/- 0.1 mm
  if (poses < 4)
    throw InvalidArgumentError("robot-calibration: at least 4 poses are needed (got " + std::to_string(poses) + ")");
  Simulation sim(seed * 104729 + 11);
  const Eigen::Isometry3d tracker_T_base = sim.pose(0.4, Eigen::Vector3d(0.0, 400.0, -1100.0), 30.0);
  std::vector<Eigen::Vector3d> flange_base, flange_tracker;
  for (int i = 0; i < poses; ++i) {
    checkCancel(context);
    context.report(0.1 + 0.8 * i / poses, "moving the robot to pose " + std::to_string(i + 1));
    // Poses spread over the reachable workspace above the patient.
    const Eigen::Vector3d p_base(sim.uniform(-250, 250), sim.uniform(-500, -250), sim.uniform(100, 400));
    flange_base.push_back(p_base);
    flange_tracker.push_back(tracker_T_base * (p_base + sim.noise(robot_noise)) + sim.noise(tracker_noise));
  }
  const auto r = registration::registerPairedPoints(flange_base, flange_tracker);
  Eigen::Isometry3d estimate = Eigen::Isometry3d::Identity();
  estimate.linear() = r.rotation;
  estimate.translation() = r.translation;
  // Error where it matters: at the patient (the screw targets lie there).
  const Eigen::Vector3d patient_base = tracker_T_base.inverse() * trackerTPatient().translation();
  const double tre_patient = (estimate * patient_base - tracker_T_base * patient_base).norm();
  StepResult result;
  result.ok = true;
  result.figures = {{"poses", poses},
                    {"fre_rms_mm", r.fre_rms_mm},
                    {"fre_expected_mm", registration::expectedFreRms(poses, std::hypot(tracker_noise, robot_noise))},
                    {"tre_at_patient_mm", tre_patient},
                    {"tre_predicted_at_patient_mm",
                     registration::predictTreRms(flange_base, patient_base, std::hypot(tracker_noise, robot_noise))},
                    {"noise_model", {{"tracker_rms_mm", tracker_noise}, {"robot_rms_mm", robot_noise}}},
                    {"transforms", {{"RobotBaseToTracker", matrixJson(estimate.matrix())}}},
                    {"simulation_truth", {{"RobotBaseToTracker", matrixJson(tracker_T_base.matrix())}}}};
  std::ostringstream s;
  s.precision(3);
  s << "RobotBaseToTracker from " << poses << " poses: FRE " << r.fre_rms_mm << " mm, error at the patient "
    << tre_patient << " mm";
  result.summary = s.str();
  return result;
}

StepResult runHmdCalibration(Session& session, const Json& params, const StepContext& context) {
  // source=hmd: the cube held on its hologram in the session's headset; file: a recording of that. Otherwise
  // the in-process simulated cube below.
  if (params.is_object() && params.contains("source") && params["source"] != "simulated") {
    return runAcquiredHmdCalibration(session, params, context);
  }
  const Params p("hmd-calibration", params,
                 {"source", "seed", "hologram_noise_mm", "tracker_noise_mm", "cube_poses", "cube_trials",
                  "checkerboard_poses"});
  const auto seed = static_cast<std::uint64_t>(p.integer("seed", 1));
  const double holo_noise = p.number("hologram_noise_mm", 1.5);
  const double tracker_noise = p.number("tracker_noise_mm", 0.25);
  const int cube_poses = p.integer("cube_poses", 3);
  // The module trials (paper 001 Fig. 7 and paper 000); 0 leaves one out.
  const int cube_trials = p.integer("cube_trials", 4);
  const int checkerboard_poses = p.integer("checkerboard_poses", 5);
  if (cube_poses < 1) throw InvalidArgumentError("hmd-calibration: cube_poses must be >= 1");
  if (cube_trials == 1 || cube_trials < 0) {
    throw InvalidArgumentError("hmd-calibration: cube_trials must be 0 (skip) or >= 2 (got " +
                               std::to_string(cube_trials) + ")");
  }
  if (checkerboard_poses < 0 || (checkerboard_poses > 0 && checkerboard_poses < 3)) {
    throw InvalidArgumentError("hmd-calibration: checkerboard_poses must be 0 (skip) or >= 3 (got " +
                               std::to_string(checkerboard_poses) + ")");
  }
  Simulation sim(seed * 15485863 + 5);
  const Eigen::Isometry3d tracker_T_hololens = sim.pose(3.0, Eigen::Vector3d(0.0, -300.0, -600.0), 50.0);
  // The 8 vertices of the 60 mm calibration cube, aligned by the user with
  // their virtual counterparts (paper 001 Eq. 2-3) at several cube poses.
  std::vector<Eigen::Vector3d> tracker_points, hololens_points;
  for (int k = 0; k < cube_poses; ++k) {
    checkCancel(context);
    context.report(0.1 + 0.8 * k / cube_poses, "aligning the virtual cube, pose " + std::to_string(k + 1));
    const Eigen::Isometry3d tracker_T_cube = sim.pose(0.6, trackerTPatient().translation(), 80.0);
    for (int v = 0; v < 8; ++v) {
      const Eigen::Vector3d vertex((v & 1) ? 30.0 : -30.0, (v & 2) ? 30.0 : -30.0, (v & 4) ? 30.0 : -30.0);
      const Eigen::Vector3d p_tracker = tracker_T_cube * vertex;
      tracker_points.push_back(p_tracker + sim.noise(tracker_noise));
      hololens_points.push_back(tracker_T_hololens.inverse() * p_tracker + sim.noise(holo_noise));
    }
  }
  Eigen::Isometry3d estimate = Eigen::Isometry3d::Identity();
  Json figures;
#ifdef MRSNS_WITH_HMD
  const auto r = hmd::calibrateCube(tracker_points, hololens_points);
  estimate = r.tracker_T_hololens;
  figures = {{"method", "hmd::calibrateCube (Eq. 2-3)"},
             {"rigid_rms_mm", r.rigid_rms_mm},
             {"affine_rms_mm", r.affine_rms_mm},
             {"dlt_condition_number", r.dlt_condition_number},
             {"affine_rigidity_deviation", r.affine_rigidity_deviation}};
#else
  const auto r = registration::registerPairedPoints(hololens_points, tracker_points);
  estimate.linear() = r.rotation;
  estimate.translation() = r.translation;
  figures = {{"method", "paired points"}, {"rigid_rms_mm", r.fre_rms_mm}};
#endif
  const Eigen::Vector3d patient_hololens = tracker_T_hololens.inverse() * trackerTPatient().translation();
  const double tre = (estimate * patient_hololens - tracker_T_hololens * patient_hololens).norm();
  figures["points"] = tracker_points.size();
  figures["tre_at_patient_mm"] = tre;
  figures["noise_model"] = {{"hologram_alignment_rms_mm", holo_noise}, {"tracker_rms_mm", tracker_noise}};
  figures["transforms"] = {{"HoloLensToTracker", matrixJson(estimate.matrix())}};
  figures["simulation_truth"] = {{"HoloLensToTracker", matrixJson(tracker_T_hololens.matrix())}};
  if (cube_trials > 0) {
    checkCancel(context);
    context.report(0.9, "paper 001 Fig. 7: compensated, uncompensated and pointer calibration trials");
    figures["cube_trial"] = cubeTrialFigures(cube_trials, seed);
  }
  if (checkerboard_poses > 0) {
    checkCancel(context);
    context.report(0.95, "paper 000: checkerboard hand-eye calibration of the HMD camera");
    figures["checkerboard_trial"] = checkerboardTrialFigures(checkerboard_poses, seed);
  }
  StepResult result;
  result.ok = true;
  result.figures = figures;
  std::ostringstream s;
  s.precision(3);
  s << "HoloLensToTracker from " << tracker_points.size() << " cube points: RMS "
    << figures["rigid_rms_mm"].get<double>() << " mm, hologram error at the patient " << tre << " mm";
  if (figures.contains("cube_trial")) {
    s << "; Fig. 7 trial RMS compensated " << figures["cube_trial"]["compensated"]["mean_rms_mm"].get<double>()
      << " / uncompensated " << figures["cube_trial"]["uncompensated"]["mean_rms_mm"].get<double>() << " / pointer "
      << figures["cube_trial"]["pointer"]["mean_rms_mm"].get<double>() << " mm";
  }
  if (figures.contains("checkerboard_trial")) {
    s << "; checkerboard RPEE " << figures["checkerboard_trial"]["rpee_mean_mm"].get<double>() << " mm";
  }
  result.summary = s.str();
  return result;
}

}  // namespace mrsns::workflow::detail
