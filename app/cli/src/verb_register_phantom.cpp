// `mrsns-cli register-phantom`: PhantomToReference from the phantom's
// landmarks touched with a tracked stylus.
#include <sstream>

#include "cli_context.h"
#include "mrsns/core/error.h"
#include "mrsns/io/device_set.h"
#include "mrsns/io/landmarks_io.h"
#include "mrsns/ultrasound/calibration_config.h"
#include "mrsns/ultrasound/phantom_registration.h"

namespace mrsns::cli {
namespace {

struct RegisterPhantomOptions {
  std::string config;
  std::string points;
  std::string output_config;
};

Report run(const RegisterPhantomOptions& options) {
  const auto config = io::readDeviceSet(options.config);
  const auto& phantom = config.requirePhantom();
  const auto points = io::readLandmarks(options.points);
  std::vector<Eigen::Vector3d> tips;
  for (const auto& p : points.points) tips.push_back(p.position);
  const auto r = ultrasound::registerPhantom(phantom, tips);
  Report report;
  Json matrix = Json::array();
  for (int i = 0; i < 16; ++i) matrix.push_back(r.reference_T_phantom.matrix()(i / 4, i % 4));
  Json per = Json::array();
  for (std::size_t i = 0; i < r.fre_mm.size(); ++i)
    per.push_back(Json{{"name", r.landmark_names[i]}, {"fre_mm", r.fre_mm[i]}});
  Json suspects = Json::array();
  for (const int s : r.suspect_landmarks) suspects.push_back(r.landmark_names[static_cast<std::size_t>(s)]);
  report.json = Json{{"verb", "register-phantom"},
                     {"phantom_to_reference", matrix},
                     {"fre_rms_mm", r.fre_rms_mm},
                     {"landmarks", per},
                     {"suspect_landmarks", suspects}};
  std::ostringstream text;
  text << "PhantomToReference from " << tips.size() << " stylus points, FRE " << r.fre_rms_mm << " mm RMS:\n"
       << r.reference_T_phantom.matrix() << "\n";
  if (!options.output_config.empty()) {
    ultrasound::writeCoordinateDefinition(options.config, options.output_config, "Phantom", "Reference",
                                          r.reference_T_phantom.matrix(), r.fre_rms_mm);
    report.json["output_config"] = options.output_config;
    text << "  written: " << options.output_config << "\n";
  }
  report.text = text.str();
  return report;
}

}  // namespace

void registerRegisterPhantomVerb(CLI::App& app, GlobalOptions& options, VerbList& verbs) {
  auto opts = std::make_shared<RegisterPhantomOptions>();
  auto* sub = app.add_subcommand("register-phantom",
                                 "PhantomToReference from the phantom definition's landmarks touched with a tracked "
                                 "stylus (points in the Reference frame, in the definition's order)");
  sub->add_option("--config", opts->config, "PLUS device-set configuration with the phantom's Landmarks")->required();
  sub->add_option("--points", opts->points, "stylus tip positions in Reference (.fcsv, .mrk.json, .csv)")->required();
  sub->add_option("--output-config", opts->output_config, "write the configuration with PhantomToReference");
  addJsonFlag(*sub, options);
  verbs.emplace_back(sub, [opts] { return run(*opts); });
}

}  // namespace mrsns::cli
