// `mrsns-cli ssm build|info|sample|convert`: statistical shape models in
// statismo's HDF5 format.
#include <filesystem>
#include <random>
#include <sstream>

#include "cli_context.h"
#include "mrsns/core/error.h"
#include "mrsns/deformation/correspondence.h"
#include "mrsns/deformation/model_building.h"
#include "mrsns/deformation/shape_model_ops.h"
#include "mrsns/io/landmarks_io.h"
#include "mrsns/io/mesh_io.h"
#include "mrsns/io/statismo_io.h"

namespace mrsns::cli {
namespace {

struct SsmOptions {
  std::vector<std::string> meshes;
  std::string model;
  std::string output;
  bool no_align = false;
  bool scale = false;
  double noise_variance = 0.0;
  int max_modes = 0;
  int count = 1;
  std::uint64_t seed = 1;
  bool double_precision = false;
  bool quality = false;
  std::string correspondence = "none";
  std::string reference;
  std::vector<std::string> landmarks;
  std::string reference_landmarks;
};

Json arrayOf(const Eigen::VectorXd& v, Eigen::Index max_count = -1) {
  Json a = Json::array();
  for (Eigen::Index i = 0; i < v.size() && (max_count < 0 || i < max_count); ++i) a.push_back(v[i]);
  return a;
}

std::vector<Eigen::Vector3d> landmarkPoints(const std::string& path) {
  std::vector<Eigen::Vector3d> v;
  for (const auto& l : io::readLandmarks(path).points) v.push_back(l.position);
  return v;
}

// --correspondence nonrigid: the reference fitted to every example (rigid +
// non-rigid ICP), so meshes from different scans share its vertices.
Json fitToExamples(const SsmOptions& o, std::vector<TriangleMesh>& meshes) {
  if (o.reference.empty()) throw InvalidArgumentError("ssm build: --correspondence nonrigid needs --reference MESH");
  if (!o.landmarks.empty() && (o.landmarks.size() != meshes.size() || o.reference_landmarks.empty())) {
    throw InvalidArgumentError("ssm build: give one --landmarks file per mesh (" + std::to_string(meshes.size()) +
                               ") and --reference-landmarks, or no landmarks");
  }
  const TriangleMesh reference = io::readMesh(o.reference);
  std::vector<std::vector<Eigen::Vector3d>> lm;
  for (const auto& f : o.landmarks) lm.push_back(landmarkPoints(f));
  std::vector<Eigen::Vector3d> ref_lm;
  if (!o.landmarks.empty()) ref_lm = landmarkPoints(o.reference_landmarks);
  const auto fits = deformation::establishCorrespondence(reference, meshes, {}, lm, ref_lm);
  Json out = Json::array();
  for (std::size_t i = 0; i < fits.size(); ++i) {
    Json f{
        {"mesh", o.meshes[i]},
        {"scale", fits[i].scale},
        {"rigid_mean_distance_mm", fits[i].rigid_mean_distance_mm},
        {"fitted_to_example_mm", {{"mean", fits[i].fitted_to_example.mean}, {"max", fits[i].fitted_to_example.max}}},
        {"example_to_fitted_mm", {{"mean", fits[i].example_to_fitted.mean}, {"max", fits[i].example_to_fitted.max}}}};
    if (!fits[i].landmark_error_mm.empty()) f["landmark_error_mm"] = fits[i].landmark_error_mm;
    out.push_back(f);
    meshes[i] = fits[i].fitted;
  }
  return out;
}

Report runBuild(const SsmOptions& o) {
  if (o.meshes.size() < 2) throw InvalidArgumentError("ssm build: give at least 2 meshes in correspondence");
  if (o.correspondence != "none" && o.correspondence != "nonrigid") {
    throw InvalidArgumentError("ssm build: --correspondence must be none or nonrigid");
  }
  std::vector<TriangleMesh> meshes;
  for (const auto& m : o.meshes) meshes.push_back(io::readMesh(m));
  Json fits;
  if (o.correspondence == "nonrigid") fits = fitToExamples(o, meshes);
  deformation::ShapeModelBuildOptions build;
  build.align = !o.no_align;
  build.procrustes.estimate_scale = o.scale;
  build.noise_variance = o.noise_variance;
  build.max_modes = o.max_modes;
  const auto result = deformation::buildShapeModel(meshes, build);
  io::StatismoWriteOptions w;
  w.double_precision = o.double_precision;
  io::writeStatismoModel(result.model, o.output, w);
  Report r;
  r.json["verb"] = "ssm build";
  r.json["output"] = o.output;
  r.json["examples"] = meshes.size();
  r.json["points"] = result.model.pointCount();
  r.json["modes"] = result.model.modeCount();
  r.json["aligned"] = build.align;
  r.json["procrustes_iterations"] = result.procrustes_iterations;
  r.json["total_variance_mm2"] = result.total_variance;
  r.json["retained_variance_fraction"] = result.retained_variance_fraction;
  r.json["variances_mm2"] = arrayOf(result.model.variances);
  r.json["correspondence"] = o.correspondence;
  if (!fits.is_null()) r.json["fits"] = fits;
  if (o.quality && meshes.size() >= 3) {
    const auto g = deformation::generalization(result.model.reference, result.aligned_shapes, build);
    std::mt19937_64 rng(o.seed);
    const auto s = deformation::specificity(result.model, result.aligned_shapes, 20, rng);
    r.json["compactness"] = arrayOf(deformation::compactness(result.model));
    r.json["generalization_mm"] = arrayOf(g.mean_error_mm);
    r.json["leave_one_out_mm"] = arrayOf(g.leave_one_out_error_mm);
    r.json["specificity_mm"] = arrayOf(s.mean_error_mm);
  }
  std::ostringstream t;
  t << "built " << o.output << ": " << meshes.size() << " examples, " << result.model.pointCount() << " points, "
    << result.model.modeCount() << " modes, " << 100.0 * result.retained_variance_fraction << "% of the variance\n";
  r.text = t.str();
  return r;
}

Report runInfo(const SsmOptions& o) {
  io::StatismoFileInfo info;
  const ShapeModel model = io::readStatismoModel(o.model, &info);
  deformation::validateShapeModel(model, o.model);
  Report r;
  r.json["verb"] = "ssm info";
  r.json["model"] = o.model;
  r.json["format_version"] = std::to_string(info.major_version) + "." + std::to_string(info.minor_version);
  r.json["representer"] = info.representer_name;
  r.json["dataset_type"] = info.dataset_type;
  r.json["build_time"] = info.build_time;
  r.json["basis_orthonormalized"] = info.basis_orthonormalized;
  r.json["points"] = model.pointCount();
  r.json["faces"] = model.reference.faceCount();
  r.json["modes"] = model.modeCount();
  r.json["noise_variance_mm2"] = model.noise_variance;
  r.json["total_variance_mm2"] = model.variances.sum();
  r.json["variances_mm2"] = arrayOf(model.variances);
  r.json["compactness"] = arrayOf(deformation::compactness(model));
  std::ostringstream t;
  t << o.model << ": statismo " << info.major_version << "." << info.minor_version << ", " << info.representer_name
    << ", " << model.pointCount() << " points, " << model.reference.faceCount() << " faces, " << model.modeCount()
    << " modes, total variance " << model.variances.sum() << " mm^2\n";
  r.text = t.str();
  return r;
}

Report runSample(const SsmOptions& o) {
  if (o.count < 1) throw InvalidArgumentError("ssm sample: --count must be >= 1");
  const ShapeModel model = io::readStatismoModel(o.model);
  std::mt19937_64 rng(o.seed);
  const std::filesystem::path out(o.output);
  Report r;
  r.json["verb"] = "ssm sample";
  r.json["model"] = o.model;
  Json samples = Json::array();
  for (int i = 0; i < o.count; ++i) {
    const Eigen::VectorXd shape = deformation::sampleShape(model, rng);
    std::filesystem::path file = out;
    if (o.count > 1)
      file = out.parent_path() / (out.stem().string() + "_" + std::to_string(i) + out.extension().string());
    io::writeMesh(deformation::shapeMesh(model, shape), file);
    Json s;
    s["file"] = file.string();
    s["mahalanobis"] = deformation::shapeMahalanobisDistance(model, shape);
    s["mean_distance_to_mean_mm"] = deformation::meanVertexDistance(shape, model.mean);
    samples.push_back(s);
    r.text += "wrote " + file.string() + "\n";
  }
  r.json["samples"] = samples;
  return r;
}

Report runConvert(const SsmOptions& o) {
  const ShapeModel model = io::readStatismoModel(o.model);
  Report r;
  r.json["verb"] = "ssm convert";
  r.json["model"] = o.model;
  r.json["output"] = o.output;
  if (std::filesystem::path(o.output).extension() == ".h5") {
    io::StatismoWriteOptions w;
    w.double_precision = o.double_precision;
    io::writeStatismoModel(model, o.output, w);
    r.json["written"] = "statismo model";
  } else {
    io::writeMesh(deformation::shapeMesh(model, model.mean), o.output);
    r.json["written"] = "mean mesh";
  }
  r.text = "wrote " + o.output + "\n";
  return r;
}

}  // namespace

void registerSsmVerbs(CLI::App& app, GlobalOptions& options, VerbList& verbs) {
  auto opts = std::make_shared<SsmOptions>();
  auto* ssm = app.add_subcommand("ssm", "statistical shape models (statismo HDF5): build, info, sample, convert");
  ssm->require_subcommand(1);

  auto* build = ssm->add_subcommand("build", "PCA shape model from meshes in correspondence (GPA + SVD)");
  build
      ->add_option("MESHES", opts->meshes,
                   "example meshes (same vertex count and order, or any with --correspondence nonrigid)")
      ->required();
  build->add_option("-o,--output", opts->output, "model file (.h5, statismo format)")->required();
  build->add_flag("--no-align", opts->no_align, "the examples are already aligned (skip Procrustes)");
  build->add_flag("--scale", opts->scale, "remove scale in the Procrustes alignment");
  build->add_option("--noise-variance", opts->noise_variance, "PPCA noise variance (mm^2)");
  build->add_option("--max-modes", opts->max_modes, "keep at most this many modes");
  build->add_flag("--double", opts->double_precision, "write float64 datasets (statismo writes float32)");
  build
      ->add_option("--correspondence", opts->correspondence,
                   "none (meshes already in correspondence) or nonrigid "
                   "(fit --reference to every mesh: rigid + non-rigid ICP)")
      ->capture_default_str();
  build->add_option("--reference", opts->reference,
                    "reference mesh for --correspondence nonrigid (its topology is kept)");
  build->add_option("--landmarks", opts->landmarks, "one landmark file per mesh (start of the rigid stage)");
  build->add_option("--reference-landmarks", opts->reference_landmarks, "the reference's landmarks, same order");
  build->add_flag("--quality", opts->quality, "also report compactness, generalisation (leave-one-out), specificity");
  addJsonFlag(*build, options);
  verbs.emplace_back(build, [opts] { return runBuild(*opts); });

  auto* info = ssm->add_subcommand("info", "summary of a statismo model");
  info->add_option("MODEL", opts->model, "statismo .h5 model")->required();
  addJsonFlag(*info, options);
  verbs.emplace_back(info, [opts] { return runInfo(*opts); });

  auto* sample = ssm->add_subcommand("sample", "random shapes of a model as meshes");
  sample->add_option("MODEL", opts->model, "statismo .h5 model")->required();
  sample->add_option("-o,--output", opts->output, "mesh file; with --count > 1 numbered _0, _1, ...")->required();
  sample->add_option("--count", opts->count, "number of samples");
  sample->add_option("--seed", opts->seed, "random seed");
  addJsonFlag(*sample, options);
  verbs.emplace_back(sample, [opts] { return runSample(*opts); });

  auto* convert = ssm->add_subcommand("convert", "rewrite a model (.h5, optionally --double) or export its mean mesh");
  convert->add_option("MODEL", opts->model, "statismo .h5 model")->required();
  convert->add_option("OUTPUT", opts->output, "output .h5 model or mesh (.vtk, .vtp, .stl, .ply, .obj)")->required();
  convert->add_flag("--double", opts->double_precision, "write float64 datasets");
  addJsonFlag(*convert, options);
  verbs.emplace_back(convert, [opts] { return runConvert(*opts); });
}

}  // namespace mrsns::cli
