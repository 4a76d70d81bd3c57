// plan-screw, import-plan and export-plan: the planned pedicle screws in the
// CT, each with its figures (clearance, breach, angles) recomputed on the
// session's models whenever the screw or the anatomy changes, and the plan
// kept as a Slicer markups file beside session.json.
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <optional>
#include <sstream>

#include "mrsns/core/error.h"
#include "mrsns/core/log.h"
#include "mrsns/io/screw_path_io.h"
#include "mrsns/registration/screw_path.h"
#include "mrsns/workflow/planning.h"
#include "patient_data.h"

namespace mrsns::workflow::detail {

namespace fs = std::filesystem;

namespace {

constexpr const char* kPlanFile = "plans/Plan.mrk.json";

std::vector<io::MarkupsLine> markupsOf(const std::vector<PlannedScrew>& plans) {
  std::vector<io::MarkupsLine> lines;
  for (const auto& s : plans) lines.push_back(io::MarkupsLine{s.name, s.entry, s.target, plannedScrewDescription(s)});
  return lines;
}

std::string sideFromDescription(const std::string& description) {
  const auto at = description.find("side=");
  if (at == std::string::npos) return {};
  std::string side = description.substr(at + 5);
  side = side.substr(0, side.find(';'));
  side.erase(side.find_last_not_of(" \t") + 1);
  return side;
}

std::string sideFromName(const std::string& name) {
  std::string lower = name;
  for (auto& c : lower) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  if (lower.find("left") != std::string::npos) return "left";
  if (lower.find("right") != std::string::npos) return "right";
  return {};
}

Json planJson(const std::vector<PlannedScrew>& plans) {
  Json list = Json::array();
  for (const auto& s : plans) list.push_back(s);
  return list;
}

}  // namespace

/// Refuses a screw that cannot be placed: degenerate, or with an end outside the patient's image.
void checkScrew(const PlannedScrew& s, const ImageEntry& ct, const std::string& step) {
  if (s.name.empty()) throw InvalidArgumentError(step + ": a screw needs a name (e.g. \"L1 left\")");
  if (!s.entry.allFinite() || !s.target.allFinite()) {
    throw InvalidArgumentError(step + ": screw '" + s.name + "' has a non-finite entry or target");
  }
  if ((s.target - s.entry).norm() < 1e-6) {
    throw InvalidArgumentError(step + ": screw '" + s.name + "' has its entry on its target: give two points");
  }
  if (!(s.diameter_mm > 0.0 && s.diameter_mm <= 15.0)) {
    throw InvalidArgumentError(step + ": screw '" + s.name + "' diameter_mm must be in (0, 15] mm");
  }
  if (!(s.length_mm >= 0.0 && s.length_mm <= 200.0)) {
    throw InvalidArgumentError(step + ": screw '" + s.name + "' length_mm must be in [0, 200] mm (0: entry to target)");
  }
  if (!s.side.empty() && s.side != "left" && s.side != "right") {
    throw InvalidArgumentError(step + ": screw '" + s.name + "' side must be left or right");
  }
  const Eigen::AlignedBox3d bounds = ctBounds(ct);
  const Eigen::Vector3d tip = s.entry + (s.length_mm > 0.0 ? s.length_mm : (s.target - s.entry).norm()) *
                                            (s.target - s.entry).normalized();
  for (const auto& [what, point] : {std::pair<const char*, Eigen::Vector3d>{"entry", s.entry}, {"target", s.target},
                                    {"tip", tip}}) {
    const double outside = bounds.exteriorDistance(point);
    if (outside > 0.0) {
      std::ostringstream out;
      out.precision(1);
      out << std::fixed << step << ": the " << what << " of screw '" << s.name << "' lies " << outside
          << " mm outside the CT: plan the screw inside the patient's image";
      throw InvalidArgumentError(out.str());
    }
  }
}

}  // namespace mrsns::workflow::detail

namespace mrsns::workflow {

PlannedScrew savePlannedScrew(Session& session, PlannedScrew screw, const PlanningAnatomyCache& anatomy,
                              const std::string& replaces) {
  const auto ct = session.ct();
  if (!ct) throw InvalidArgumentError("plan: import the patient's CT first (import-ct): screws are planned on it");
  const std::string old_name = replaces.empty() ? screw.name : replaces;
  auto plans = session.plans();
  auto it = std::find_if(plans.begin(), plans.end(), [&](const PlannedScrew& s) { return s.name == old_name; });
  if (screw.name != old_name &&
      std::any_of(plans.begin(), plans.end(), [&](const PlannedScrew& s) { return s.name == screw.name; })) {
    throw InvalidArgumentError("plan: a screw named '" + screw.name + "' exists already");
  }
  detail::checkScrew(screw, *ct, "plan");
  screw.figures = anatomy.evaluate(screw);
  if (!anatomy.warnings().empty()) screw.figures["anatomy_warnings"] = anatomy.warnings();
  if (screw.vertebra.empty() && screw.figures["vertebra"].is_string()) {
    screw.vertebra = screw.figures["vertebra"].get<std::string>();
  }
  if (screw.side.empty() && screw.figures["angles"].is_object()) {
    const std::string side = screw.figures["angles"].value("side", "");
    if (side == "left" || side == "right") screw.side = side;
  }
  if (screw.provenance.source.empty()) {
    screw.provenance.source = "user";
    screw.provenance.step = "plan-screw";
  }
  screw.provenance.time = detail::madeBy("plan-screw").time;
  if (it != plans.end()) {
    *it = screw;
  } else {
    plans.push_back(screw);
  }
  detail::writePlanFile(session, plans);
  session.setPlans(plans);
  return screw;
}

std::string nameForNewScrew(const std::vector<PlannedScrew>& plans, const nlohmann::json& figures) {
  const auto taken = [&](const std::string& name) {
    return std::any_of(plans.begin(), plans.end(), [&](const PlannedScrew& s) { return s.name == name; });
  };
  if (figures.is_object() && figures.contains("vertebra") && figures["vertebra"].is_string() &&
      figures.contains("angles") && figures["angles"].is_object()) {
    const std::string side = figures["angles"].value("side", "");
    const std::string named = figures["vertebra"].get<std::string>() + (side.empty() ? "" : " " + side);
    if (!taken(named)) return named;
  }
  std::string name;
  for (std::size_t n = plans.size() + 1;; ++n) {
    name = "Screw " + std::to_string(n);
    if (!taken(name)) return name;
  }
}

bool removePlannedScrew(Session& session, const std::string& name) {
  auto plans = session.plans();
  const auto it = std::find_if(plans.begin(), plans.end(), [&](const PlannedScrew& s) { return s.name == name; });
  if (it == plans.end()) return false;
  plans.erase(it);
  detail::writePlanFile(session, plans);
  session.setPlans(plans);
  return true;
}

}  // namespace mrsns::workflow

namespace mrsns::workflow::detail {

void writePlanFile(Session& session, const std::vector<PlannedScrew>& plans) {
  fs::create_directories(session.resolve("plans"));
  std::error_code ec;
  if (plans.empty()) {
    fs::remove(session.resolve(kPlanFile), ec);
  } else {
    io::writeMarkupsLines(markupsOf(plans), session.resolve(kPlanFile));
  }
}

Json refreshPlanFigures(Session& session) {
  auto plans = session.plans();
  Json by_name = Json::object();
  if (!plans.empty()) {
    const PlanningAnatomyCache anatomy(session);
    for (auto& s : plans) {
      try {
        s.figures = anatomy.evaluate(s);
      } catch (const InvalidArgumentError& e) {
        s.figures = {{"error", e.what()}};
      }
      if (!anatomy.warnings().empty()) s.figures["anatomy_warnings"] = anatomy.warnings();
      by_name[s.name] = s.figures;
    }
  }
  writePlanFile(session, plans);
  session.setPlans(plans);
  return by_name;
}

StepResult runPlanScrew(Session& session, const Json& params, const StepContext& /*context*/) {
  const Params p("plan-screw", params,
                 {"name", "entry", "target", "diameter_mm", "length_mm", "vertebra", "side", "remove", "rename"});
  const auto ct = session.ct();
  if (!ct) throw InvalidArgumentError("plan-screw: import the patient's CT first (import-ct): screws are planned on it");
  auto plans = session.plans();
  std::string name = p.text("name", "");
  std::optional<PlanningAnatomyCache> anatomy;
  if (name.empty()) {
    // A new screw named from the anatomy, as the GUI names a screw clicked on the slices.
    if (p.boolean("remove", false) || p.has("rename")) {
      throw InvalidArgumentError("plan-screw: give name= the screw to change (e.g. \"L1 left\")");
    }
    if (!p.has("entry") || !p.has("target")) {
      throw InvalidArgumentError("plan-screw: a new screw needs entry= and target= (\"x,y,z\" in the CT, mm)");
    }
    PlannedScrew probe;
    probe.name = "new screw";
    probe.entry = pointParam(params, "entry", "plan-screw");
    probe.target = pointParam(params, "target", "plan-screw");
    probe.diameter_mm = p.number("diameter_mm", probe.diameter_mm);
    probe.length_mm = p.number("length_mm", probe.length_mm);
    checkScrew(probe, *ct, "plan-screw");
    anatomy.emplace(session);
    name = nameForNewScrew(plans, anatomy->evaluate(probe));
  }
  auto it = std::find_if(plans.begin(), plans.end(), [&](const PlannedScrew& s) { return s.name == name; });
  StepResult result;
  if (p.boolean("remove", false)) {
    if (it == plans.end()) throw InvalidArgumentError("plan-screw: there is no screw '" + name + "' to remove");
    removePlannedScrew(session, name);
    plans = session.plans();
    Json left = Json::object();
    for (const auto& s : plans) left[s.name] = s.figures;
    result.figures["plan"] = left;
    result.outputs.push_back(kPlanFile);
    result.ok = true;
    result.summary = "removed screw " + name + " (" + std::to_string(plans.size()) + " left)";
    return result;
  }
  const bool adding = it == plans.end();
  PlannedScrew screw = adding ? PlannedScrew{} : *it;
  if (adding) {
    screw.name = name;
    if (!p.has("entry") || !p.has("target")) {
      throw InvalidArgumentError("plan-screw: a new screw needs entry= and target= (\"x,y,z\" in the CT, mm)");
    }
    screw.side = sideFromName(name);
    screw.provenance = madeBy("plan-screw");
    screw.provenance.source = "user";
  }
  if (p.has("entry")) screw.entry = pointParam(params, "entry", "plan-screw");
  if (p.has("target")) screw.target = pointParam(params, "target", "plan-screw");
  screw.diameter_mm = p.number("diameter_mm", screw.diameter_mm);
  screw.length_mm = p.number("length_mm", screw.length_mm);
  if (p.has("vertebra")) screw.vertebra = vertebraName(p.text("vertebra", "")).empty() ? p.text("vertebra", "")
                                                                                       : vertebraName(p.text("vertebra", ""));
  if (p.has("side")) screw.side = p.text("side", "");
  if (p.has("rename")) {
    const std::string renamed = p.text("rename", "");
    if (renamed != name && std::any_of(plans.begin(), plans.end(), [&](const auto& s) { return s.name == renamed; })) {
      throw InvalidArgumentError("plan-screw: a screw named '" + renamed + "' exists already");
    }
    screw.name = renamed;
  }
  if (!anatomy) anatomy.emplace(session);
  savePlannedScrew(session, screw, *anatomy, adding ? std::string() : name);
  Json figures = Json::object();
  for (const auto& s : session.plans()) figures[s.name] = s.figures;
  result.figures["screw"] = session.plan(screw.name).value_or(screw);
  result.figures["plan"] = figures;
  result.outputs.push_back(kPlanFile);
  result.ok = true;
  std::ostringstream summary;
  summary.precision(1);
  summary << std::fixed << (adding ? "planned " : "updated ") << screw.name;
  const Json& f = figures.contains(screw.name) ? figures[screw.name] : Json::object();
  if (f.contains("breach") && f["breach"].is_object()) {
    summary << ": breach " << f["breach"].value("max_breach_mm", 0.0) << " mm ("
            << f["breach"].value("grade", "?") << ")";
  }
  if (f.contains("clearance") && f["clearance"].is_object() && f["clearance"]["vessel"].is_object()) {
    summary << ", " << f["clearance"]["vessel"].value("min_clearance_mm", 0.0) << " mm from "
            << f["clearance"]["vessel"].value("name", "the vessel");
  }
  result.summary = summary.str();
  return result;
}

StepResult runImportPlan(Session& session, const Json& params, const StepContext& context) {
  const Params p("import-plan", params, {"path", "replace"});
  const auto ct = session.ct();
  if (!ct) throw InvalidArgumentError("import-plan: import the CT the plan was made on first (import-ct)");
  const std::string path = p.text("path", "");
  if (path.empty()) throw InvalidArgumentError("import-plan: give path= a Slicer markups file of lines (.mrk.json)");
  context.report(0.1, "reading " + fs::path(path).filename().string());
  const auto lines = io::readMarkupsLines(path);
  std::vector<PlannedScrew> imported;
  for (const auto& line : lines) {
    const auto parsed = registration::screwPathFromLine(line.name, line.start, line.end, line.description);
    PlannedScrew s;
    s.name = line.name;
    s.vertebra = parsed.vertebra;
    s.entry = parsed.entry;
    s.target = parsed.target;
    s.diameter_mm = parsed.diameter_mm;
    s.length_mm = parsed.length_mm;
    s.side = sideFromDescription(line.description);
    if (s.side.empty()) s.side = sideFromName(s.name);
    s.provenance = madeBy("import-plan", fs::absolute(path).string());
    checkScrew(s, *ct, "import-plan");
    imported.push_back(s);
  }
  auto plans = p.boolean("replace", false) ? std::vector<PlannedScrew>{} : session.plans();
  for (const auto& s : imported) {
    auto it = std::find_if(plans.begin(), plans.end(), [&](const PlannedScrew& o) { return o.name == s.name; });
    if (it != plans.end()) {
      *it = s;
    } else {
      plans.push_back(s);
    }
  }
  session.setPlans(plans);
  context.report(0.5, "evaluating the screws on the session's models");
  StepResult result;
  result.figures["plan"] = refreshPlanFigures(session);
  result.figures["imported"] = imported.size();
  result.outputs.push_back(kPlanFile);
  result.ok = true;
  result.summary = "imported " + std::to_string(imported.size()) + " screw(s) (" + std::to_string(plans.size()) +
                   " in the plan)";
  return result;
}

StepResult runExportPlan(Session& session, const Json& params, const StepContext& /*context*/) {
  const Params p("export-plan", params, {"path"});
  const std::string path = p.text("path", "");
  if (path.empty()) throw InvalidArgumentError("export-plan: give path= the .mrk.json to write (Slicer markups lines)");
  const auto plans = session.plans();
  if (plans.empty()) throw InvalidArgumentError("export-plan: the session has no planned screw (plan-screw, import-plan)");
  io::writeMarkupsLines(markupsOf(plans), path);
  StepResult result;
  result.figures["path"] = fs::absolute(path).string();
  result.figures["screws"] = planJson(plans);
  result.ok = true;
  result.summary = "wrote " + std::to_string(plans.size()) + " screw(s) to " + path;
  return result;
}

}  // namespace mrsns::workflow::detail
