#include "step_navigation_soft_tissue.h"

#include <cmath>
#include <fstream>

#include "mrsns/core/error.h"
#include "mrsns/workflow/navigation_soft_tissue.h"
#include "mrsns/workflow/session.h"

namespace mrsns::workflow::detail {
namespace {

}  // namespace

void configureNavigationSoftTissue(const Session& session, const Params& params, NavigationOptions& options) {
  const std::string mode = params.text("soft_tissue", "auto");
  if (mode != "auto" && mode != "on" && mode != "off") {
    throw InvalidArgumentError("navigation: soft_tissue '" + mode + "' is not one of auto, on, off");
  }
  auto& robot = options.robot;
  robot.soft_tissue_margin_mm = params.number("soft_tissue_margin_mm", robot.soft_tissue_margin_mm);
  robot.soft_tissue_margin_sd = params.number("soft_tissue_sd", robot.soft_tissue_margin_sd);
  if (!(robot.soft_tissue_margin_mm >= 0.0 && robot.soft_tissue_margin_mm <= 50.0)) {
    throw InvalidArgumentError("navigation: soft_tissue_margin_mm must be in [0, 50] mm");
  }
  if (!(robot.soft_tissue_margin_sd >= 0.0 && robot.soft_tissue_margin_sd <= 10.0)) {
    throw InvalidArgumentError("navigation: soft_tissue_sd must be in [0, 10] standard deviations");
  }
  auto& st = options.soft_tissue;
  st.observation_sd_mm = params.number("observation_sd_mm", st.observation_sd_mm);
  if (!(st.observation_sd_mm > 0.0 && st.observation_sd_mm <= 20.0)) {
    throw InvalidArgumentError("navigation: observation_sd_mm must be in (0, 20] mm");
  }
  st.observation_lifetime_frames = params.integer("observation_lifetime_frames", st.observation_lifetime_frames);
  if (st.observation_lifetime_frames < 0) {
    throw InvalidArgumentError("navigation: observation_lifetime_frames must be >= 0 (0: keep every observation)");
  }
  const std::string probe_tool = params.text("probe_tool", "Probe");
  if (probe_tool.empty() || probe_tool.find_first_of(" \t/") != std::string::npos) {
    throw InvalidArgumentError("navigation: probe_tool '" + probe_tool + "' is not a tool name (e.g. Probe)");
  }
  st.probe_transform = probe_tool + "ToTracker";
  if (mode == "off") return;

  std::vector<std::string> missing;
  if (options.devices.source == "simulated") missing.push_back("a source that delivers ultrasound (source=plus or playback)");
  st.patient_transform = robot.patient_transform;
  for (auto& m : applySessionSoftTissue(session, options)) missing.push_back(std::move(m));
  if (!missing.empty()) {
    options.soft_tissue.shape_model.clear();  // off
    if (mode == "auto") return;
    std::string text;
    for (const auto& m : missing) text += (text.empty() ? "" : "; ") + m;
    throw InvalidArgumentError("navigation: soft_tissue=on needs " + text);
  }
}

Json navigationSoftTissueFigures(const Session& session, const NavigationOptions& options, const NavigationLoop& loop,
                                 const std::filesystem::path& file) {
  const NavigationStatus st = loop.status();
  auto finite = [](double v) { return std::isfinite(v) ? Json(v) : Json(nullptr); };
  Json figures = {{"state", st.soft_tissue},
                  {"frames_received", st.us_frames_received},
                  {"frames_used", st.us_frames_used},
                  {"frames_skipped", st.us_frames_skipped},
                  {"frames_refused", st.us_frames_refused},
                  {"frames_off_tissue", st.us_frames_off_tissue},
                  {"updates", st.soft_tissue_updates},
                  {"observations", st.soft_tissue_observations},
                  {"sd_max_near_path_mm", finite(st.soft_tissue_sd_max_mm)},
                  {"frame_to_margin_ms", finite(st.us_frame_to_margin_ms)}};
  if (options.soft_tissue.shape_model.empty()) return figures;
  const auto samples = loop.softTissueSeries();
  Json updates = Json::array();
  for (const auto& s : samples) {
    updates.push_back({{"timestamp", s.timestamp},
                       {"coefficients", std::vector<double>(s.coefficients.data(),
                                                            s.coefficients.data() + s.coefficients.size())},
                       {"observations", s.observations},
                       {"frame_to_margin_ms", s.frame_to_margin_ms},
                       {"contours", s.contours}});
  }
  Json ct_T_model = Json::array();
  for (int r = 0; r < 4; ++r) {
    for (int c = 0; c < 4; ++c) ct_T_model.push_back(options.soft_tissue.ct_T_model.matrix()(r, c));
  }
  const Json record = {
      {"format", "mrsns-soft-tissue/1"},
      {"shape_model", std::filesystem::relative(options.soft_tissue.shape_model, session.folder()).generic_string()},
      {"ct_T_model", ct_T_model},
      {"observation_sd_mm", options.soft_tissue.observation_sd_mm},
      {"observation_lifetime_frames", options.soft_tissue.observation_lifetime_frames},
      {"updates", updates}};
  std::filesystem::create_directories(file.parent_path());
  std::ofstream out(file);
  out << record.dump() << '\n';
  if (!out) throw FileError("navigation: cannot write " + file.string());
  figures["file"] = std::filesystem::relative(file, session.folder()).generic_string();
  return figures;
}

}  // namespace mrsns::workflow::detail
