// Patient registration: the dispatch between the live acquisition
// (source=plus, the default once connect-devices used a PlusServer or when
// host/port are given: step_registration_live.cpp), its recomputation from a
// recording (source=file), and the in-process simulated patient
// (source=simulated, below): the session's CT fiducials and bone placed at a
// seeded patient pose, touched with noise, which this step then scores
// itself. The simulated variant remains for the in-process workflow until
// every step acquires from mrsns-sim; its figures carry the simulation truth
// and say so.
#include <algorithm>
#include <array>
#include <cmath>
#include <filesystem>
#include <sstream>

#include "mrsns/registration/paired_point.h"
#include "mrsns/registration/surface_registration.h"
#include "registration_ct.h"
#include "simulation.h"
#include "step_internal.h"

namespace mrsns::workflow::detail {

StepResult runRegistration(Session& session, const Json& params, const StepContext& context) {
  std::string source = "simulated";
  const auto devices = session.step("connect-devices");
  if (devices.is_object() && devices.value("status", "") == "ok" && devices.contains("params") &&
      devices["params"].value("source", "") == "plus") {
    source = "plus";
  }
  // A tracker named in the parameters means a live acquisition from it.
  if (params.is_object() && (params.contains("host") || params.contains("port"))) source = "plus";
  if (params.is_object() && params.contains("source") && params["source"].is_string()) {
    source = params["source"].get<std::string>();
  }
  if (source == "plus" || source == "file") return runAcquiredRegistration(session, params, context);
  if (source != "simulated") {
    throw InvalidArgumentError("registration: source must be plus (live), file (a recording) or simulated, not '" +
                               source + "'");
  }
  return runSimulatedRegistration(session, params, context);
}

StepResult runSimulatedRegistration(Session& session, const Json& params, const StepContext& context) {
  const Params p("registration", params,
                 {"source", "seed", "landmark_noise_mm", "surface_points", "surface_noise_mm"});
  const auto seed = static_cast<std::uint64_t>(p.integer("seed", 1));
  const double fle = p.number("landmark_noise_mm", 0.5);
  const double surface_noise = p.number("surface_noise_mm", 0.3);
  const int surface_points = p.integer("surface_points", 400);
  if (fle < 0.0 || surface_noise < 0.0 || surface_points < 10) {
    throw InvalidArgumentError("registration: noise must be >= 0 mm and surface_points >= 10");
  }
  // The session's CT, touched by an in-process simulated stylus: its fiducials and bone are the simulated
  // patient's, placed at a seeded pose this step then scores itself against.
  context.report(0.05, "reading the CT's bone models and fiducials");
  const SessionRegistrationTargets ct = sessionRegistrationTargets(session, "registration");
  const auto& bone = ct.bone;
  checkCancel(context);

  // The patient lies somewhere in the tracker's field of view.
  Simulation sim(seed * 7919 + 3);
  const Eigen::Isometry3d patient_T_ct = sim.pose(0.5, Eigen::Vector3d::Zero(), 50.0);

  context.report(0.5, "landmark registration");
  std::vector<Eigen::Vector3d> landmarks_ct, landmarks_patient;
  for (const auto& position : ct.fiducials_ct) {
    landmarks_ct.push_back(position);
    landmarks_patient.push_back(patient_T_ct * position + sim.noise(fle));
  }
  const auto pp = registration::registerPairedPoints(landmarks_ct, landmarks_patient);
  Eigen::Isometry3d landmark_patient_T_ct = Eigen::Isometry3d::Identity();
  landmark_patient_T_ct.linear() = pp.rotation;
  landmark_patient_T_ct.translation() = pp.translation;
  checkCancel(context);

  context.report(0.6, "surface registration (ICP)");
  // Points a surgeon can reach: the posterior half of the exposed vertebrae.
  std::vector<Eigen::Vector3d> surface_patient;
  std::vector<Eigen::Index> candidates;
  const double y_mid = bone.vertices.col(1).mean();
  for (Eigen::Index i = 0; i < bone.vertices.rows(); ++i) {
    if (bone.vertices(i, 1) > y_mid) candidates.push_back(i);
  }
  std::shuffle(candidates.begin(), candidates.end(), sim.engine());
  for (int i = 0; i < surface_points && i < static_cast<int>(candidates.size()); ++i) {
    const Eigen::Vector3d v = bone.vertices.row(candidates[static_cast<std::size_t>(i)]).transpose();
    surface_patient.push_back(patient_T_ct * v + sim.noise(surface_noise));
  }
  registration::IcpOptions icp_options;
  icp_options.max_correspondence_distance_mm = 5.0;
  const auto icp = registration::registerSurface(surface_patient, bone, landmark_patient_T_ct.inverse(), icp_options);
  const Eigen::Isometry3d icp_patient_T_ct = icp.fixed_T_moving.inverse();
  checkCancel(context);

  // Target registration error at the planned screw entries and targets.
  std::vector<double> tre_landmarks, tre_icp;
  Json targets = Json::array();
  for (const auto& screw : ct.plans) {
    for (const auto& [what, point] : {std::pair{"entry", screw.entry}, std::pair{"target", screw.target}}) {
      const Eigen::Vector3d truth = patient_T_ct * point;
      tre_landmarks.push_back((landmark_patient_T_ct * point - truth).norm());
      tre_icp.push_back((icp_patient_T_ct * point - truth).norm());
      targets.push_back({{"path", screw.name},
                         {"point", what},
                         {"tre_landmarks_mm", tre_landmarks.back()},
                         {"tre_surface_mm", tre_icp.back()},
                         {"tre_predicted_mm", registration::predictTreRms(landmarks_ct, point, fle)}});
    }
  }
  StepResult result;
  result.ok = icp.converged || icp.rms_mm < 3.0 * surface_noise + 0.5;
  result.figures = {{"landmarks",
                     {{"count", landmarks_ct.size()},
                      {"fre_rms_mm", pp.fre_rms_mm},
                      {"fre_expected_mm", registration::expectedFreRms(static_cast<int>(landmarks_ct.size()), fle)},
                      {"tre", statsJson(tre_landmarks)}}},
                    {"surface",
                     {{"points", surface_patient.size()},
                      {"rms_mm", icp.rms_mm},
                      {"iterations", icp.iterations},
                      {"converged", icp.converged},
                      {"inlier_fraction", icp.inlier_fraction},
                      {"tre", statsJson(tre_icp)}}},
                    {"targets", targets},
                    {"ct", ct.ct_name},
                    {"source", "simulated"},
                    {"noise_model", {{"landmark_fle_rms_mm", fle}, {"surface_noise_rms_mm", surface_noise}}},
                    {"transforms", {{"CTToPatient", matrixJson(icp_patient_T_ct.matrix())}}},
                    {"simulation_truth", {{"CTToPatient", matrixJson(patient_T_ct.matrix())}}}};
  std::ostringstream s;
  s.precision(3);
  s << "landmarks FRE " << pp.fre_rms_mm << " mm, surface RMS " << icp.rms_mm << " mm";
  if (!tre_icp.empty()) s << ", TRE at the screw paths " << result.figures["surface"]["tre"]["rms"].get<double>() << " mm RMS";
  s << " (in-process simulated patient)";
  result.summary = s.str();
  return result;
}

}  // namespace mrsns::workflow::detail
