// import-phantom: the patient data of MR-SNS's cervical phantom (the CT a lab
// gets by scanning the printed phantom, its segmentation and the planned
// screws), generated as `mrsns-cli make-phantom` writes them, then imported
// as any user's data: the CT, its label map, the bone and vessel models, the
// fiducial screws found in the CT image by their metal, and the plan. The
// phantom's fiducial ground truth is never written here.
#include <algorithm>
#include <filesystem>
#include <sstream>

#include "mrsns/core/error.h"
#include "mrsns/io/image_io.h"
#include "mrsns/io/screw_path_io.h"
#include "mrsns/registration/label_names.h"
#include "mrsns/registration/phantom_cervical.h"
#include "mrsns/workflow/planning.h"
#include "patient_data.h"

namespace mrsns::workflow::detail {

namespace fs = std::filesystem;

StepResult runImportPhantom(Session& session, const Json& params, const StepContext& context) {
  const Params p("import-phantom", params, {"spacing_mm", "seed", "noise_hu", "hmd_triangles"});
  registration::PhantomOptions options;
  options.spacing_mm = p.number("spacing_mm", 0.8);
  options.seed = static_cast<std::uint64_t>(p.integer("seed", 1));
  options.noise_sigma_hu = p.number("noise_hu", 15.0);
  const int hmd = p.integer("hmd_triangles", 20000);
  if (session.ct()) {
    throw InvalidArgumentError("import-phantom: the session already has a CT ('" + session.ct()->name +
                               "'): the phantom's data go into a new session");
  }
  context.report(0.02, "generating the cervical phantom's CT");
  const auto phantom = registration::generateCervicalPhantom(options);
  checkCancel(context);
  const std::string folder = "phantom";
  fs::create_directories(session.resolve(folder));
  const fs::path ct_file = session.resolve(folder + "/phantom_ct.nrrd");
  const fs::path labels_file = session.resolve(folder + "/phantom_labels.nrrd");
  const fs::path plan_file = session.resolve(folder + "/screw_paths.mrk.json");
  io::writeImage(phantom.ct, ct_file);
  io::writeImage(phantom.labels, labels_file);
  std::vector<io::MarkupsLine> lines;
  for (const auto& path : phantom.screw_paths) {
    PlannedScrew screw;
    screw.vertebra = path.vertebra;
    screw.diameter_mm = path.diameter_mm;
    screw.length_mm = path.length_mm;
    screw.side = path.name.find("left") != std::string::npos ? "left" : "right";
    lines.push_back(io::MarkupsLine{path.name, path.entry, path.target, plannedScrewDescription(screw)});
  }
  io::writeMarkupsLines(lines, plan_file);
  checkCancel(context);

  StepResult result;
  result.outputs = {folder + "/phantom_ct.nrrd", folder + "/phantom_labels.nrrd", folder + "/screw_paths.mrk.json"};
  Json steps = Json::object();
  const auto run = [&](const std::string& step, const Json& step_params, double from, double to) {
    StepContext sub;
    sub.cancel = context.cancel;
    sub.progress = [&](double f, const std::string& message) {
      context.report(from + (to - from) * f, step + ": " + message);
    };
    const StepResult r = runStep(session, step, step_params, sub);
    if (r.cancelled) throw Cancelled{};
    if (!r.ok) throw ComputationError("import-phantom: " + step + " did not succeed: " + r.summary);
    steps[step] = r.summary;
  };
  run("import-ct", {{"path", ct_file.string()}, {"name", "cervical phantom"}}, 0.1, 0.3);
  run("import-label-map",
      {{"path", labels_file.string()}, {"scheme", "verse"}, {"name", "phantom segmentation"}, {"id", "labels"}}, 0.3,
      0.4);
  std::string vertebrae;
  for (const auto& v : phantom.vertebrae) vertebrae += (vertebrae.empty() ? "" : ",") + v.name;
  run("make-models", {{"labels", vertebrae}, {"hmd_triangles", hmd}}, 0.4, 0.65);
  run("make-models",
      {{"labels", std::to_string(registration::kPhantomVesselLabel)},
       {"role", "vessel"},
       {"hmd_triangles", hmd},
       {"target_triangles", 4000}},
      0.65, 0.75);
  // The fiducials from the CT image itself (titanium far above bone), not from the segmentation. The
  // phantom's 2 mm screw shafts partial-volume below the clinical 2000 HU at 1.5 mm voxels (the head and
  // shaft of two screws then show no voxel above it), so the threshold sits between its cortex (900 HU,
  // noise sigma tens of HU) and that partial-volume level.
  const double metal_hu = std::min(2000.0, registration::PhantomDensities::cortical_bone + 700.0);
  run("find-fiducials", {{"source", "threshold"}, {"threshold_hu", metal_hu}}, 0.75, 0.9);
  run("import-plan", {{"path", plan_file.string()}}, 0.9, 1.0);
  // Generated, not scanned: every entry made from the phantom says so (a simulated patient is never presented
  // as a measurement of a real one).
  if (auto ct = session.ct()) {
    ct->provenance.simulated = true;
    session.setCt(*ct);
  }
  for (auto labels : session.labelMaps()) {
    labels.provenance.simulated = true;
    session.putLabelMap(labels);
  }
  auto models = session.models();
  for (auto& m : models) m.provenance.simulated = true;
  session.putModels(models);
  if (auto fiducials = session.fiducials()) {
    fiducials->provenance.simulated = true;
    session.setFiducials(*fiducials);
  }
  auto plans = session.plans();
  for (auto& screw : plans) screw.provenance.simulated = true;
  session.setPlans(plans);
  result.figures["steps"] = steps;
  result.figures["phantom"] = {{"spacing_mm", options.spacing_mm},
                               {"seed", options.seed},
                               {"noise_hu", options.noise_sigma_hu},
                               {"vertebrae", vertebrae},
                               {"generator", "registration::generateCervicalPhantom (mrsns-cli make-phantom)"}};
  const auto fiducials = session.fiducials();
  result.ok = true;
  std::ostringstream s;
  s << "cervical phantom: CT " << phantom.ct.size[0] << "x" << phantom.ct.size[1] << "x" << phantom.ct.size[2]
    << " at " << options.spacing_mm << " mm, " << session.models().size() << " models, "
    << (fiducials ? fiducials->points.size() : 0) << " fiducials found in the CT, " << session.plans().size()
    << " planned screws";
  result.summary = s.str();
  return result;
}

}  // namespace mrsns::workflow::detail
