// `mrsns-cli deform-trial`: the simulated phantom protocol of paper 001
// §III.A (Table I): posterior shape from B-mode slices vs the undeformed prior.
#include <filesystem>
#include <fstream>
#include <sstream>

#include "cli_context.h"
#include "mrsns/core/error.h"
#include "mrsns/deformation/deformation_trial.h"
#include "mrsns/deformation/simulated_sweep.h"
#include "mrsns/io/mesh_io.h"
#include "mrsns/io/sequence_file.h"
#include "mrsns/io/statismo_io.h"
#include "mrsns/io/transform_io.h"

namespace mrsns::cli {
namespace {

struct DeformTrialOptions {
  int cases = 6;
  std::uint64_t seed = 1;
  int frames = 90;
  double calibration_error_mm = 1.2;
  double tracking_noise_mm = 0.35;
  double noise_sigma_mm = 1.5;
  double stretch_mm = 2.0;
  std::string write_case;
  std::string correspondence = "arc-length";
  std::string overlap = "split";
  double contour_gate = 0.0;
  bool keep_implausible = false;
};

Json summary(const deformation::Summary& s) {
  return Json{{"mean", s.mean}, {"sd", s.sd}, {"max", s.max}};
}

deformation::DeformationTrialOptions trialOptions(const DeformTrialOptions& o) {
  deformation::DeformationTrialOptions t;
  t.cases = o.cases;
  t.seed = o.seed;
  t.frames = o.frames;
  t.calibration_error_mm = o.calibration_error_mm;
  t.tracking_noise_mm = o.tracking_noise_mm;
  t.noise_sigma_mm = o.noise_sigma_mm;
  t.stretch_mm = o.stretch_mm;
  if (o.correspondence == "arc-length") {
    t.tracker.correspondence = deformation::ContourCorrespondence::ArcLength;
  } else if (o.correspondence == "closest-point") {
    t.tracker.correspondence = deformation::ContourCorrespondence::ClosestPoint;
  } else {
    throw InvalidArgumentError("deform-trial: --correspondence must be arc-length or closest-point");
  }
  if (o.overlap != "split" && o.overlap != "refuse") {
    throw InvalidArgumentError("deform-trial: --overlap must be split or refuse");
  }
  t.segmentation.split_overlapping = o.overlap == "split";
  if (!(o.contour_gate >= 0.0)) throw InvalidArgumentError("deform-trial: --contour-gate must be >= 0 (0 = off)");
  t.tracker.contour_gate_mahalanobis = o.contour_gate;
  t.tracker.reject_implausible_frames = !o.keep_implausible;
  return t;
}

// One simulated case as files, the input of `deform-track`: model.h5 and
// truth.vtp (Reference frame), sweep.igs.mha (8-bit B-mode, ProbeToTracker,
// ReferenceToTracker), ImageToProbe.txt (with the calibration error and the
// pixel scale) and contours.json (the ground truth's cut per frame: an ideal
// external segmenter, image mm).
Report writeCase(const DeformTrialOptions& o) {
  const auto t = trialOptions(o);
  const deformation::SimulatedSweep sweep = deformation::simulateSweep(t, o.seed);
  const std::filesystem::path dir(o.write_case);
  std::filesystem::create_directories(dir);
  io::writeStatismoModel(sweep.model, dir / "model.h5");
  io::writeMesh(sweep.truth, dir / "truth.vtp");
  io::writeSequence(dir / "sweep.igs.mha", sweep.sequence);
  io::writeChildToParent(sweep.image_to_probe, dir / "ImageToProbe.txt");  // the plain probe_T_image
  Json frames = Json::array();
  for (std::size_t f = 0; f < sweep.true_contours.size(); ++f) {
    Json contours = Json::array();
    for (const auto& c : sweep.true_contours[f]) {
      Json pts = Json::array();
      for (const auto& p : c.points) pts.push_back({p.x(), p.y()});
      contours.push_back(pts);
    }
    frames.push_back({{"frame", f}, {"contours", contours}});
  }
  std::ofstream(dir / "contours.json")
      << Json{{"format", "mrsns-contours"}, {"version", 1}, {"units", "mm"}, {"frames", frames}}.dump();
  Json fid = Json::array();
  for (int v : sweep.fiducial_vertices) fid.push_back(v);
  Report r;
  r.json["verb"] = "deform-trial";
  r.json["case_directory"] = dir.string();
  r.json["files"] = {"model.h5", "truth.vtp", "sweep.igs.mha", "ImageToProbe.txt", "contours.json"};
  r.json["frames"] = sweep.sequence.frames.size();
  r.json["model_frame"] = "Reference";
  r.json["fiducial_vertices"] = fid;
  r.text = "wrote one simulated case to " + dir.string() + "\n";
  return r;
}

Report run(const DeformTrialOptions& o) {
  if (o.cases < 1 || o.frames < 1) throw InvalidArgumentError("deform-trial: --cases and --frames must be >= 1");
  if (!o.write_case.empty()) return writeCase(o);
  const auto t = trialOptions(o);
  const auto r = deformation::runDeformationTrial(t);
  Report rep;
  rep.json["verb"] = "deform-trial";
  rep.json["cases"] = o.cases;
  rep.json["seed"] = o.seed;
  rep.json["frames_per_case"] = o.frames;
  rep.json["correspondence"] = o.correspondence;
  rep.json["overlap"] = o.overlap;
  rep.json["contour_gate"] = o.contour_gate;
  rep.json["reject_implausible_frames"] = !o.keep_implausible;
  rep.json["model"] = {{"training_shapes", t.training_shapes}, {"modes", r.model_modes}, {"points", r.model_points}};
  rep.json["noise_model"] = {{"us_calibration_error_rms_mm", t.calibration_error_mm},
                             {"us_calibration_rotation_deg", t.calibration_rotation_deg},
                             {"tracking_noise_rms_mm", t.tracking_noise_mm},
                             {"tracking_rotation_deg", t.tracking_rotation_deg},
                             {"speckle", "Rayleigh, 3x3 resolution cell"},
                             {"attenuation_per_mm", t.bmode.attenuation_per_mm},
                             {"pixel_mm", t.bmode.spacing_mm},
                             {"stretch_rms_mm", t.stretch_mm},
                             {"posterior_sigma_mm", t.noise_sigma_mm}};
  // Table I of paper 001: E^SD (Eq. 22) and E^FP (Eq. 21).
  rep.json["surface_distance_mm"] = {{"mean", r.posterior_sd_mean_mm.mean},
                                     {"sd", r.posterior_sd_mean_mm.sd},
                                     {"max", r.posterior_sd_max_mm.max},
                                     {"max_mean", r.posterior_sd_max_mm.mean}};
  rep.json["fiducial_error_mm"] = summary(r.posterior_fp_mm);
  rep.json["prior"] = {{"surface_distance_mm",
                        {{"mean", r.prior_sd_mean_mm.mean},
                         {"sd", r.prior_sd_mean_mm.sd},
                         {"max", r.prior_sd_max_mm.max},
                         {"max_mean", r.prior_sd_max_mm.mean}}},
                       {"fiducial_error_mm", summary(r.prior_fp_mm)}};
  rep.json["posterior_update_ms"] = {{"p50", r.update_ms_p50}, {"p99", r.update_ms_p99}};
  rep.json["segmentation_ms"] = {{"p50", r.segmentation_ms_p50}};
  rep.json["paper"] = {{"surface_distance_mm", {{"mean", 1.52}, {"sd", 0.43}}},
                       {"fiducial_error_mm", {{"mean", 2.19}, {"sd", 0.21}}}};
  Json per_case = Json::array();
  for (const auto& c : r.cases) {
    per_case.push_back({{"posterior_sd_mean_mm", c.posterior_sd_mean_mm},
                        {"posterior_sd_max_mm", c.posterior_sd_max_mm},
                        {"posterior_fp_mm", c.posterior_fp_mm},
                        {"prior_sd_mean_mm", c.prior_sd_mean_mm},
                        {"prior_fp_mm", c.prior_fp_mm},
                        {"frames_updated", c.frames_updated},
                        {"contours_segmented", c.contours_segmented},
                        {"contours_refused", c.contours_refused},
                        {"contours_split", c.contours_split},
                        {"observations", c.observations},
                        {"excluded", c.excluded},
                        {"mahalanobis", c.posterior_mahalanobis}});
  }
  rep.json["per_case"] = per_case;
  std::ostringstream t2;
  t2.precision(3);
  t2 << "deform-trial: " << o.cases << " cases, " << o.frames << " frames each\n"
     << "              E^SD mean (mm)      E^SD max  E^FP (mm)\n"
     << "posterior     " << r.posterior_sd_mean_mm.mean << " +/- " << r.posterior_sd_mean_mm.sd << "    "
     << r.posterior_sd_max_mm.max << "     " << r.posterior_fp_mm.mean << " +/- " << r.posterior_fp_mm.sd << "\n"
     << "prior         " << r.prior_sd_mean_mm.mean << " +/- " << r.prior_sd_mean_mm.sd << "    "
     << r.prior_sd_max_mm.max << "     " << r.prior_fp_mm.mean << " +/- " << r.prior_fp_mm.sd << "\n"
     << "paper 001     1.52 +/- 0.43                 2.19 +/- 0.21\n"
     << "posterior update p50 " << r.update_ms_p50 << " ms, p99 " << r.update_ms_p99 << " ms\n";
  rep.text = t2.str();
  return rep;
}

}  // namespace

void registerDeformTrialVerb(CLI::App& app, GlobalOptions& options, VerbList& verbs) {
  auto opts = std::make_shared<DeformTrialOptions>();
  auto* sub = app.add_subcommand("deform-trial",
                                 "simulated carotid phantom protocol (paper 001 Table I): posterior shape from "
                                 "B-mode slices vs the prior");
  sub->add_option("--cases", opts->cases, "number of cases (held-out shapes)")->capture_default_str();
  sub->add_option("--seed", opts->seed, "random seed")->capture_default_str();
  sub->add_option("--frames", opts->frames, "ultrasound frames per sweep")->capture_default_str();
  sub->add_option("--calibration-error", opts->calibration_error_mm, "US calibration error, 3D RMS (mm)")
      ->capture_default_str();
  sub->add_option("--tracking-noise", opts->tracking_noise_mm, "tracking noise, 3D RMS (mm)")->capture_default_str();
  sub->add_option("--sigma", opts->noise_sigma_mm, "posterior observation noise sigma (mm)")->capture_default_str();
  sub->add_option("--stretch", opts->stretch_mm, "shape stretch amplitude, RMS per axis (mm)")->capture_default_str();
  sub->add_option("--overlap", opts->overlap,
                  "overlapping branch loops near the bifurcation: split (segment each lumen without the shared "
                  "side) or refuse (as ambiguous)")
      ->capture_default_str();
  sub->add_option("--contour-gate", opts->contour_gate,
                  "refuse a contour whose RMS Mahalanobis distance from the posterior predictive exceeds this "
                  "(0 = off)")
      ->capture_default_str();
  sub->add_flag("--keep-implausible", opts->keep_implausible,
                "keep frames whose observations make the posterior implausible (default: undo them)");
  sub->add_option("--correspondence", opts->correspondence,
                  "feature-to-model contour pairing: arc-length (paper, Eq. 8 + cyclic shift) or closest-point")
      ->capture_default_str();
  sub->add_option("--write-case", opts->write_case,
                  "write one simulated case (model, truth, tracked B-mode sweep, calibration, ideal contours) to "
                  "this directory instead of running the trial");
  addJsonFlag(*sub, options);
  verbs.emplace_back(sub, [opts] { return run(*opts); });
}

}  // namespace mrsns::cli
