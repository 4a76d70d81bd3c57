// `mrsns-cli plan-check`: clearance of planned screw paths (Slicer line
// markups) to a surface mesh along their length.
#include <sstream>

#include "cli_context.h"
#include "json_vectors.h"
#include "mrsns/core/mesh_locator.h"
#include "mrsns/io/mesh_io.h"
#include "mrsns/io/screw_path_io.h"
#include "mrsns/registration/screw_path.h"

namespace mrsns::cli {
namespace {

struct PlanCheckOptions {
  std::string paths;
  std::string surface;
  double step_mm = 1.0;
};

Report run(const PlanCheckOptions& options) {
  const auto lines = io::readMarkupsLines(options.paths);
  const auto mesh = io::readMesh(options.surface);
  const MeshLocator surface(mesh);
  registration::ClearanceOptions co;
  co.step_mm = options.step_mm;

  Report report;
  report.json["verb"] = "plan-check";
  report.json["paths_file"] = options.paths;
  report.json["surface"] = options.surface;
  Json list = Json::array();
  std::ostringstream text;
  text << "Screw path clearance to " << options.surface << '\n';
  int cutting = 0;
  for (const auto& line : lines) {
    const auto path = registration::screwPathFromLine(line.name, line.start, line.end, line.description);
    const auto c = registration::screwPathClearance(path, surface, co);
    Json profile = Json::array();
    for (const auto& s : c.profile) profile.push_back(Json{{"depth_mm", s.depth_mm}, {"clearance_mm", s.clearance_mm}});
    list.push_back(Json{{"name", path.name},
                        {"vertebra", path.vertebra},
                        {"entry_mm", vectorJson(path.entry)},
                        {"target_mm", vectorJson(path.target)},
                        {"diameter_mm", path.diameter_mm},
                        {"length_mm", path.effectiveLength()},
                        {"min_clearance_mm", c.min_clearance_mm},
                        {"min_depth_mm", c.min_depth_mm},
                        {"min_surface_point_mm", vectorJson(c.min_surface_point)},
                        {"cuts_surface", c.cuts_surface},
                        {"crossings_mm", c.crossings_mm},
                        {"profile", profile}});
    cutting += c.cuts_surface ? 1 : 0;
    text << "  " << path.name << (path.vertebra.empty() ? "" : " (" + path.vertebra + ")") << ": min clearance "
         << c.min_clearance_mm << " mm at " << c.min_depth_mm << " mm depth"
         << (c.cuts_surface ? "  CUTS THE SURFACE" : "") << '\n';
  }
  report.json["paths"] = list;
  report.json["paths_cutting_surface"] = cutting;
  report.text = text.str();
  return report;
}

}  // namespace

void registerPlanCheckVerb(CLI::App& app, GlobalOptions& options, VerbList& verbs) {
  auto opts = std::make_shared<PlanCheckOptions>();
  auto* sub = app.add_subcommand("plan-check",
                                 "Clearance of planned screw paths (Slicer Line markups: entry, target; description "
                                 "'vertebra=..; diameter_mm=..; length_mm=..') to a surface mesh along their length");
  sub->add_option("--paths", opts->paths, "screw paths (.mrk.json with Line markups)")->required();
  sub->add_option("--surface", opts->surface, "surface mesh to keep clear of (e.g. a vessel or soft tissue)")
      ->required();
  sub->add_option("--step", opts->step_mm, "profile sampling step (mm)")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  addJsonFlag(*sub, options);
  verbs.emplace_back(sub, [opts] { return run(*opts); });
}

}  // namespace mrsns::cli
