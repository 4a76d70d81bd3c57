// `mrsns-cli robot-calibrate`: robot-tracker calibration from recorded stations. The pose CSV
// (io/pose_csv.h) holds one pair per station, in this order: the robot's FlangeToBase (base_T_flange),
// then the tracker's MarkerToTracker (tracker_T_marker).
#include <sstream>

#include "cli_context.h"
#include "mrsns/core/error.h"
#include "mrsns/core/rigid.h"
#include "mrsns/io/pose_csv.h"
#include "mrsns/robot/robot_tracker_calibration.h"

namespace mrsns::cli {
namespace {

struct RobotCalibrateOptions {
  std::string poses;
};

Json matrixJson(const Eigen::Isometry3d& T) {
  const auto v = toRowMajor(T);
  return Json(std::vector<double>(v.begin(), v.end()));
}

Report run(const RobotCalibrateOptions& o) {
  const auto csv = io::readPoseCsv(o.poses);
  if (csv.poses.size() % 2 != 0) {
    throw FormatError("robot-calibrate: " + o.poses + " has " + std::to_string(csv.poses.size()) +
                      " poses; it needs pairs (FlangeToBase, then MarkerToTracker) for each station");
  }
  std::vector<Eigen::Isometry3d> flange, marker;
  for (std::size_t i = 0; i < csv.poses.size(); i += 2) {
    flange.push_back(csv.poses[i]);
    marker.push_back(csv.poses[i + 1]);
  }
  const auto r = robot::calibrateRobotTracker(flange, marker);
  Report rep;
  rep.json["verb"] = "robot-calibrate";
  rep.json["poses"] = o.poses;
  rep.json["stations"] = r.poses;
  rep.json["MarkerToFlange"] = matrixJson(r.flange_T_marker);
  rep.json["TrackerToBase"] = matrixJson(r.base_T_tracker);
  rep.json["residual_rms_mm"] = r.translation_rms_mm;
  rep.json["residual_rms_deg"] = r.rotation_rms_rad * 180.0 / M_PI;
  rep.json["axis_spread_deg"] = r.axis_spread_rad * 180.0 / M_PI;
  Json per = Json::array();
  for (std::size_t i = 0; i < r.translation_residual_mm.size(); ++i) {
    per.push_back({{"station", i},
                   {"translation_mm", r.translation_residual_mm[i]},
                   {"rotation_deg", r.rotation_residual_rad[i] * 180.0 / M_PI}});
  }
  rep.json["residuals"] = per;
  std::ostringstream t;
  t.precision(4);
  t << "robot-calibrate: " << r.poses << " stations, residual RMS " << r.translation_rms_mm << " mm / "
    << r.rotation_rms_rad * 180.0 / M_PI << " deg, axis spread " << r.axis_spread_rad * 180.0 / M_PI << " deg\n"
    << "MarkerToFlange translation (mm): " << r.flange_T_marker.translation().transpose() << "\n"
    << "TrackerToBase translation (mm):  " << r.base_T_tracker.translation().transpose() << "\n";
  rep.text = t.str();
  return rep;
}

}  // namespace

void registerRobotCalibrateVerb(CLI::App& app, GlobalOptions& options, VerbList& verbs) {
  auto o = std::make_shared<RobotCalibrateOptions>();
  auto* sub = app.add_subcommand(
      "robot-calibrate", "robot-tracker calibration (AX=YB): MarkerToFlange and TrackerToBase from station pairs");
  sub->add_option("--poses", o->poses, "pose CSV: per station FlangeToBase then MarkerToTracker (16 or 17 columns)")
      ->required();
  addJsonFlag(*sub, options);
  verbs.emplace_back(sub, [o] { return run(*o); });
}

}  // namespace mrsns::cli
