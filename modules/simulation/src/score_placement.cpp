// The robot's placement judged by where the drill truly went: the room's drill tip (its marker's true pose,
// the true tip on it) in the CT through the patient reference's true pose at every tracker tick of each
// path the workstation drove, against the session's planned path.
#include "score_placement.h"

#include <Eigen/Eigenvalues>
#include <cmath>
#include <optional>

#include "score_json.h"

namespace mrsns::simulation {

using namespace score_detail;

namespace {

Eigen::Vector3d vec3(const Json& j) {
  return {j.at(0).get<double>(), j.at(1).get<double>(), j.at(2).get<double>()};
}

struct TipSample {
  double utc = 0.0;
  Eigen::Vector3d ct;  ///< the true drill tip in the CT frame
};

/// The true drill tip in the CT at every truth sample within [from, to] (utc).
std::vector<TipSample> trueTipInCt(const Json& truth, double from, double to, int marker, int reference,
                                   const Eigen::Vector3d& tip_marker, const Eigen::Isometry3d& reference_T_ct) {
  std::vector<TipSample> out;
  const Eigen::Isometry3d ct_T_reference = reference_T_ct.inverse();
  for (const auto& s : truth.at("tracker_samples")) {
    const double utc = s.at("utc").get<double>();
    if (utc < from || utc > to) continue;
    const auto& poses = s.at("poses");
    const Eigen::Isometry3d tracker_T_marker = compactPose(poses.at(static_cast<std::size_t>(marker)));
    const Eigen::Isometry3d tracker_T_reference = compactPose(poses.at(static_cast<std::size_t>(reference)));
    out.push_back({utc, ct_T_reference * tracker_T_reference.inverse() * (tracker_T_marker * tip_marker)});
  }
  return out;
}

int toolIndex(const Json& truth, const std::string& name) {
  const auto& tools = truth.at("tools");
  for (std::size_t i = 0; i < tools.size(); ++i) {
    if (tools[i].get<std::string>() == name) return static_cast<int>(i);
  }
  return -1;
}

/// The line through `points` (least squares: their centroid and principal direction), oriented along `along`.
std::pair<Eigen::Vector3d, Eigen::Vector3d> fitLine(const std::vector<Eigen::Vector3d>& points,
                                                    const Eigen::Vector3d& along) {
  Eigen::Vector3d centroid = Eigen::Vector3d::Zero();
  for (const auto& p : points) centroid += p;
  centroid /= static_cast<double>(points.size());
  Eigen::Matrix3d scatter = Eigen::Matrix3d::Zero();
  for (const auto& p : points) scatter += (p - centroid) * (p - centroid).transpose();
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(scatter);
  Eigen::Vector3d direction = eig.eigenvectors().col(2);
  if (direction.dot(along) < 0.0) direction = -direction;
  return {centroid, direction};
}

struct TipMotion {
  double path_mm = 0.0;          ///< the length of the tip's path
  double displacement_mm = 0.0;  ///< the farthest it got from where it was
  double rest_utc = 0.0;         ///< from then on slower than 1 mm/s
};

/// The true tip's motion from `utc` to the end of the samples.
TipMotion motionFrom(const std::vector<TipSample>& tips, double utc) {
  TipMotion m;
  m.rest_utc = utc;
  const TipSample* first = nullptr;
  const TipSample* previous = nullptr;
  for (const auto& s : tips) {
    if (s.utc < utc) continue;
    if (first == nullptr) first = &s;
    if (previous != nullptr) {
      const double step_mm = (s.ct - previous->ct).norm();
      m.path_mm += step_mm;
      if (step_mm / std::max(1e-6, s.utc - previous->utc) > 1.0) m.rest_utc = s.utc;
    }
    m.displacement_mm = std::max(m.displacement_mm, (s.ct - first->ct).norm());
    previous = &s;
  }
  return m;
}

/// The last fault of the room's timeline (its event, its utc) to begin within [from, to].
std::optional<std::pair<std::string, double>> lastFaultBefore(const Json& truth, double from, double to) {
  std::optional<std::pair<std::string, double>> found;
  for (const auto& e : truth.value("events", Json::array())) {
    const std::string what = e.value("event", std::string());
    const double utc = e.value("utc", 0.0);
    // Not an end ("occlusion end PatientToTracker", "video_freeze end").
    if (utc < from || utc > to || what.find(" end") != std::string::npos) continue;
    for (const char* kind :
         {"occlusion", "tracker_disconnect", "patient_shift", "video_freeze", "robot_protective_stop"}) {
      if (what.rfind(kind, 0) == 0) found = std::pair{what, utc};
    }
  }
  return found;
}

double angleDeg(const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  return std::acos(std::clamp(a.normalized().dot(b.normalized()), -1.0, 1.0)) * 180.0 / M_PI;
}

}  // namespace

void scoreRobotPlacement(const Json& session, const Json& truth, Json& scored, Json& not_scored) {
  const Json& st = truth.at("static");
  const Json* step = session.contains("steps") && session["steps"].contains("robot-placement")
                         ? &session["steps"]["robot-placement"]
                         : nullptr;
  if (step == nullptr || !step->contains("figures") || !fromSimulatedRoom(*step) ||
      !(*step)["figures"].contains("paths")) {
    not_scored.push_back("robot-placement (not run, or not driven in mrsns-sim's room)");
    return;
  }
  if (!st.contains("robot_marker_tool") || !st.contains("patient_reference_tool") || !st.contains("CTToReference") ||
      !st.contains("tool_tips_mm")) {
    not_scored.push_back("robot-placement (the room has no robot or no patient to judge it by)");
    return;
  }
  const std::string marker_tool = st["robot_marker_tool"].get<std::string>();
  const int marker = toolIndex(truth, marker_tool);
  const int reference = toolIndex(truth, st["patient_reference_tool"].get<std::string>());
  if (marker < 0 || reference < 0 || !st["tool_tips_mm"].contains(marker_tool)) {
    not_scored.push_back("robot-placement (the truth did not record the drill's marker or the patient reference)");
    return;
  }
  const Eigen::Vector3d tip_marker = vec3(st["tool_tips_mm"][marker_tool]);
  const Eigen::Isometry3d reference_T_ct(matrix(st["CTToReference"], "truth CTToReference"));

  Json paths = Json::array();
  std::vector<double> entry_errors, target_errors, angle_errors, depth_errors;
  Json stops = Json::array();
  for (const auto& p : (*step)["figures"]["paths"]) {
    const std::string name = p.value("name", std::string("?"));
    if (!p.contains("utc_start") || !p.contains("utc_end") || !p.contains("entry_ct") || !p.contains("target_ct")) {
      not_scored.push_back("robot-placement path " + name + " (no time window or plan in the session)");
      continue;
    }
    const Eigen::Vector3d entry = vec3(p["entry_ct"]), target = vec3(p["target_ct"]);
    const Eigen::Vector3d axis = (target - entry).normalized();
    const auto tips = trueTipInCt(truth, p["utc_start"].get<double>(), p["utc_end"].get<double>(), marker, reference,
                                  tip_marker, reference_T_ct);
    Json r = {{"name", name}, {"outcome", p.value("outcome", std::string("?"))}, {"truth_samples", tips.size()}};
    if (tips.empty()) {
      r["why_not_scored"] = "no truth sample in the path's time window";
      paths.push_back(r);
      continue;
    }
    // The deepest the true tip went along the planned axis once aligned on it (the approach from the previous
    // screw passes elsewhere), within 10 mm of the axis: the hole's end.
    const double aligned_utc = p.contains("utc_aligned") ? p["utc_aligned"].get<double>() : 0.0;
    const TipSample* deepest = nullptr;
    for (const auto& s : tips) {
      const double depth = (s.ct - entry).dot(axis);
      if (s.utc < aligned_utc || (s.ct - entry - depth * axis).norm() > 10.0) continue;
      if (deepest == nullptr || depth > (deepest->ct - entry).dot(axis)) deepest = &s;
    }
    r["planned_depth_mm"] = (target - entry).norm();
    if (deepest == nullptr) {
      r["why_not_scored"] = "the true tip never came within 10 mm of the planned axis";
      paths.push_back(r);
      continue;
    }
    r["depth_reached_mm"] = (deepest->ct - entry).dot(axis);
    if (p.value("outcome", std::string()) == "placed" && p.contains("utc_aligned") && p.contains("utc_path_finished")) {
      // The drilled line: the true tip from the alignment to the path's end (the advance), least squares.
      std::vector<Eigen::Vector3d> advance;
      for (const auto& s : tips) {
        if (s.utc >= p["utc_aligned"].get<double>() && s.utc <= p["utc_path_finished"].get<double>()) {
          advance.push_back(s.ct);
        }
      }
      if (advance.size() >= 10) {
        const auto [on_line, direction] = fitLine(advance, axis);
        // Where the drilled line crosses the plane of the planned entry (normal to the planned axis).
        const double along = (entry - on_line).dot(axis) / direction.dot(axis);
        const Eigen::Vector3d achieved_entry = on_line + along * direction;
        const Eigen::Vector3d achieved_target = deepest->ct;
        r["entry_error_mm"] = (achieved_entry - entry).norm();
        r["target_error_mm"] = (achieved_target - target).norm();
        r["angle_error_deg"] = angleDeg(direction, axis);
        r["depth_error_mm"] = r["depth_reached_mm"].get<double>() - r["planned_depth_mm"].get<double>();
        r["achieved_entry_ct"] = {achieved_entry.x(), achieved_entry.y(), achieved_entry.z()};
        r["achieved_target_ct"] = {achieved_target.x(), achieved_target.y(), achieved_target.z()};
        entry_errors.push_back(r["entry_error_mm"].get<double>());
        target_errors.push_back(r["target_error_mm"].get<double>());
        angle_errors.push_back(r["angle_error_deg"].get<double>());
        depth_errors.push_back(std::abs(r["depth_error_mm"].get<double>()));
      } else {
        r["why_not_scored"] = "fewer than 10 truth samples while advancing";
      }
    }
    if (p.contains("utc_stop")) {
      // After the stop command: how far the true tip still went, and when it came to rest (slower than
      // 1 mm/s from then on).
      const double utc_stop = p["utc_stop"].get<double>();
      const TipMotion after_stop = motionFrom(tips, utc_stop);
      Json stop = {{"path", name},
                   {"reason", p.value("stop_reason", std::string())},
                   {"tip_path_after_stop_mm", after_stop.path_mm},
                   {"tip_displacement_after_stop_mm", after_stop.displacement_mm},
                   {"time_to_rest_s", after_stop.rest_utc - utc_stop},
                   {"workstation_stop_latency_ms", p.value("stop_latency_ms", Json(nullptr))},
                   {"workstation_time_to_stop_s", p.value("time_to_stop_s", Json(nullptr))}};
      // The room's fault that caused it (the last one to begin in the path before the stop): from its onset,
      // which the workstation cannot see, to the stop command and to the arm at rest.
      if (const auto fault = lastFaultBefore(truth, p["utc_start"].get<double>(), utc_stop)) {
        const TipMotion after_fault = motionFrom(tips, fault->second);
        stop["fault"] = fault->first;
        stop["fault_to_stop_command_ms"] = 1e3 * (utc_stop - fault->second);
        stop["fault_to_rest_s"] = after_stop.rest_utc - fault->second;
        stop["tip_path_after_fault_mm"] = after_fault.path_mm;
      }
      r["stop"] = stop;
      stops.push_back(stop);
    }
    paths.push_back(r);
  }
  Json out = {{"definition",
               "the room's true drill tip in the CT (its marker's and the patient reference's true poses at every "
               "tracker tick of each path's time window) against the session's planned path: entry error where "
               "the drilled line (least squares through the tip while advancing) crosses the plane of the planned "
               "entry; target error from the deepest tip to the planned target; angle between the drilled line "
               "and the planned axis; after a stop, how far the tip still went and when it came to rest"},
              {"paths", paths},
              {"placed", entry_errors.size()},
              {"stops", stops}};
  if (!entry_errors.empty()) {
    out["entry_error"] = stats(entry_errors);
    out["target_error"] = stats(target_errors);
    out["depth_error"] = stats(depth_errors);
    double sum = 0.0, worst = 0.0;
    for (double a : angle_errors) {
      sum += a;
      worst = std::max(worst, a);
    }
    out["angle_error_deg"] = {{"mean", sum / static_cast<double>(angle_errors.size())}, {"max", worst}};
  }
  scored["robot_placement"] = out;
}

}  // namespace mrsns::simulation
