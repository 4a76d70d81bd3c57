// `mrsns-cli register-points FIXED MOVING`: landmark registration with FRE,
// predicted TRE and leave-one-out checks.
#include <map>
#include <set>
#include <sstream>

#include "cli_context.h"
#include "json_vectors.h"
#include "mrsns/core/error.h"
#include "mrsns/io/landmarks_io.h"
#include "mrsns/io/transform_io.h"
#include "mrsns/registration/paired_point.h"
#include "pose_source.h"

namespace mrsns::cli {
namespace {

struct RegisterPointsOptions {
  std::string fixed;
  std::string moving;
  std::string targets;
  std::string output;
  std::string pair_by = "auto";
  bool scale = false;
  double fle_mm = -1.0;
};

bool uniqueLabels(const LandmarkSet& set) {
  std::set<std::string> labels;
  for (const auto& p : set.points) {
    if (p.label.empty() || !labels.insert(p.label).second) return false;
  }
  return true;
}

// Pairs points by label when both files name the same unique labels (order
// then does not matter), else by order.
std::vector<std::pair<std::size_t, std::size_t>> pairPoints(const LandmarkSet& fixed, const LandmarkSet& moving,
                                                            const std::string& pair_by, std::string& used) {
  std::vector<std::pair<std::size_t, std::size_t>> pairs;
  const bool labels_usable = uniqueLabels(fixed) && uniqueLabels(moving);
  if (pair_by == "label" || (pair_by == "auto" && labels_usable)) {
    if (!labels_usable) {
      throw InvalidArgumentError("cannot pair by label: a file has empty or repeated labels; use --pair-by order");
    }
    std::map<std::string, std::size_t> moving_index;
    for (std::size_t i = 0; i < moving.points.size(); ++i) moving_index[moving.points[i].label] = i;
    std::vector<std::string> unmatched;
    for (std::size_t i = 0; i < fixed.points.size(); ++i) {
      const auto it = moving_index.find(fixed.points[i].label);
      if (it == moving_index.end()) {
        unmatched.push_back(fixed.points[i].label);
      } else {
        pairs.emplace_back(i, it->second);
      }
    }
    if (pair_by == "label" || pairs.size() == fixed.points.size()) {
      if (!unmatched.empty() || fixed.points.size() != moving.points.size()) {
        std::string list;
        for (const auto& u : unmatched) list += (list.empty() ? "" : ", ") + u;
        throw InvalidArgumentError("the landmark files do not name the same points (" +
                                   std::to_string(fixed.points.size()) + " fixed, " +
                                   std::to_string(moving.points.size()) + " moving" +
                                   (list.empty() ? std::string() : "; only in fixed: " + list) +
                                   "): digitise the missing points or remove the extra ones");
      }
      used = "label";
      return pairs;
    }
    pairs.clear();  // labels differ entirely (e.g. F-1.. vs P-1..): fall back to order
  }
  if (fixed.points.size() != moving.points.size()) {
    throw InvalidArgumentError("the landmark files hold different numbers of points (" +
                               std::to_string(fixed.points.size()) + " fixed, " + std::to_string(moving.points.size()) +
                               " moving): both must list the same landmarks in the same order");
  }
  for (std::size_t i = 0; i < fixed.points.size(); ++i) pairs.emplace_back(i, i);
  used = "order";
  return pairs;
}

Report run(const RegisterPointsOptions& options) {
  const auto fixed = io::readLandmarks(options.fixed);
  const auto moving = io::readLandmarks(options.moving);
  std::string pairing;
  const auto pairs = pairPoints(fixed, moving, options.pair_by, pairing);
  std::vector<Eigen::Vector3d> fixed_points;
  std::vector<Eigen::Vector3d> moving_points;
  for (const auto& [f, m] : pairs) {
    fixed_points.push_back(fixed.points[f].position);
    moving_points.push_back(moving.points[m].position);
  }
  registration::PairedPointOptions reg_options;
  reg_options.estimate_scale = options.scale;
  const auto result = registration::registerPairedPoints(moving_points, fixed_points, reg_options);

  Report report;
  report.json["verb"] = "register-points";
  report.json["fixed"] = options.fixed;
  report.json["moving"] = options.moving;
  report.json["pairing"] = pairing;
  report.json["points"] = pairs.size();
  Json matrix = Json::array();
  for (int r = 0; r < 4; ++r) {
    for (int c = 0; c < 4; ++c) matrix.push_back(result.fixed_T_moving.matrix()(r, c));
  }
  report.json["fixed_T_moving"] = matrix;
  report.json["scale"] = result.scale;
  report.json["fre_rms_mm"] = result.fre_rms_mm;
  report.json["fle_rms_estimate_mm"] = result.fle_rms_estimate_mm;
  const double fle = options.fle_mm >= 0.0 ? options.fle_mm : result.fle_rms_estimate_mm;
  report.json["fle_used_for_tre_mm"] = fle;
  Json per_point = Json::array();
  for (std::size_t i = 0; i < pairs.size(); ++i) {
    Json p{{"label", fixed.points[pairs[i].first].label}, {"fre_mm", result.fre_mm[i]}};
    if (!result.leave_one_out_mm.empty()) {
      p["leave_one_out_mm"] = std::isnan(result.leave_one_out_mm[i]) ? Json(nullptr) : Json(result.leave_one_out_mm[i]);
    }
    per_point.push_back(p);
  }
  report.json["per_point"] = per_point;
  Json suspects = Json::array();
  for (int s : result.suspect_points) suspects.push_back(fixed.points[pairs[static_cast<std::size_t>(s)].first].label);
  report.json["suspect_points"] = suspects;

  std::ostringstream text;
  text << "Landmark registration (" << pairs.size() << " points paired by " << pairing << ")\n"
       << "  FRE RMS: " << result.fre_rms_mm << " mm (implied FLE " << result.fle_rms_estimate_mm << " mm)\n";
  for (std::size_t i = 0; i < pairs.size(); ++i) {
    text << "    " << fixed.points[pairs[i].first].label << ": FRE " << result.fre_mm[i] << " mm";
    if (!result.leave_one_out_mm.empty()) text << ", left out " << result.leave_one_out_mm[i] << " mm";
    text << '\n';
  }
  if (!result.suspect_points.empty()) {
    text << "  SUSPECT points (left-out error implausible for the others' FLE):";
    for (const auto& s : suspects) text << ' ' << s.get<std::string>();
    text << "\n  Re-digitise them or check their labels.\n";
  }
  if (!options.targets.empty()) {
    const auto targets = io::readLandmarks(options.targets);
    Json tre = Json::array();
    for (const auto& t : targets.points) {
      const double predicted = registration::predictTreRms(moving_points, t.position, fle);
      tre.push_back(Json{{"label", t.label},
                         {"position_moving_mm", vectorJson(t.position)},
                         {"position_fixed_mm", vectorJson(result.fixed_T_moving * t.position)},
                         {"predicted_tre_rms_mm", predicted}});
      text << "  target " << t.label << ": predicted TRE " << predicted << " mm RMS\n";
    }
    report.json["targets"] = tre;
  }
  if (!options.output.empty()) {
    // The node MovingToFixed: fixed_T_moving, by io/transform_io.h's convention whatever the extension.
    io::writeChildToParent(result.fixed_T_moving.matrix(), options.output);
    report.json["output"] = options.output;
    text << "  written: " << options.output << " (apply it to the moving data in 3D Slicer)\n";
  }
  report.text = text.str();
  return report;
}

}  // namespace

void registerRegisterPointsVerb(CLI::App& app, GlobalOptions& options, VerbList& verbs) {
  auto opts = std::make_shared<RegisterPointsOptions>();
  auto* sub = app.add_subcommand(
      "register-points",
      "Paired-point (landmark) registration of MOVING onto FIXED (Slicer .mrk.json/.fcsv/.csv): rigid or with "
      "isotropic scale; FRE per point, leave-one-out check for a wrong point, predicted TRE at targets");
  sub->add_option("FIXED", opts->fixed, "landmarks in the fixed frame (e.g. digitised on the patient)")->required();
  sub->add_option("MOVING", opts->moving, "the same landmarks in the moving frame (e.g. picked in the CT)")->required();
  sub->add_flag("--scale", opts->scale, "also estimate an isotropic scale");
  sub->add_option("--pair-by", opts->pair_by, "pair points by 'label', by 'order', or 'auto' (labels when usable)")
      ->check(CLI::IsMember({"auto", "label", "order"}))
      ->capture_default_str();
  sub->add_option("--targets", opts->targets, "targets in the moving frame: predicted TRE at each (Fitzpatrick-West)");
  sub->add_option("--fle", opts->fle_mm,
                  "fiducial localisation error RMS (mm) for the TRE prediction; default: "
                  "implied by the FRE");
  sub->add_option(
      "--output", opts->output,
      "write the transform MovingToFixed (fixed_T_moving): .tfm/.h5/.mat as 3D Slicer reads them (the inverse, "
      "LPS), .txt the plain 4x4 fixed_T_moving");
  addJsonFlag(*sub, options);
  verbs.emplace_back(sub, [opts] { return run(*opts); });
}

}  // namespace mrsns::cli
