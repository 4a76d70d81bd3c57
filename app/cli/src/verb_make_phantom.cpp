// `mrsns-cli make-phantom --output DIR`: the bundled cervical phantom (CT,
// label map, meshes, fiducial ground truth, planned screw paths, manifest).
#include <chrono>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "cli_context.h"
#include "mrsns/core/error.h"
#include "mrsns/io/image_io.h"
#include "mrsns/io/landmarks_io.h"
#include "mrsns/io/screw_path_io.h"
#include "mrsns/registration/label_meshing.h"
#include "mrsns/registration/phantom_cervical.h"
#include "segment_output.h"

namespace mrsns::cli {
namespace {

struct MakePhantomOptions {
  std::string output;
  double spacing_mm = 0.8;
  std::uint64_t seed = 1;
  double noise_hu = 15.0;
  std::size_t target_triangles = 20000;
  std::string format = "stl";
};

Json matrixJson(const Eigen::Matrix3d& m) {
  Json rows = Json::array();
  for (int r = 0; r < 3; ++r) rows.push_back(Json::array({m(r, 0), m(r, 1), m(r, 2)}));
  return rows;
}

Report run(const MakePhantomOptions& options) {
  const std::filesystem::path dir(options.output);
  std::error_code ec;
  std::filesystem::create_directories(dir, ec);
  if (ec || !std::filesystem::is_directory(dir)) {
    throw FileError("cannot create the output folder '" + options.output + "': " + ec.message());
  }
  registration::PhantomOptions phantom_options;
  phantom_options.spacing_mm = options.spacing_mm;
  phantom_options.seed = options.seed;
  phantom_options.noise_sigma_hu = options.noise_hu;
  const auto start = std::chrono::steady_clock::now();
  const auto phantom = registration::generateCervicalPhantom(phantom_options);
  const double generate_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();

  const auto ct_file = dir / "phantom_ct.nrrd";
  const auto labels_file = dir / "phantom_labels.nrrd";
  io::writeImage(phantom.ct, ct_file);
  io::writeImage(phantom.labels, labels_file);
  const auto fiducials_file = dir / "fiducials_truth.mrk.json";
  io::writeLandmarks(phantom.fiducials_truth, fiducials_file);
  std::vector<io::MarkupsLine> lines;
  for (const auto& path : phantom.screw_paths) {
    lines.push_back(io::MarkupsLine{path.name, path.entry, path.target, registration::screwPathDescription(path)});
  }
  const auto paths_file = dir / "screw_paths.mrk.json";
  io::writeMarkupsLines(lines, paths_file);

  // Vertebrae from the bone alone (no screw holes: the fiducial landmarks lie
  // on that surface); vessel and screws from the full label map.
  std::string text;
  registration::LabelMeshOptions mesh_options;
  mesh_options.target_triangles = options.target_triangles;
  mesh_options.scheme = registration::LabelScheme::Verse;
  auto vertebrae = registration::meshLabelMap(phantom.bone_labels, mesh_options);
  mesh_options.labels = {registration::kPhantomVesselLabel, registration::kPhantomScrewLabel};
  mesh_options.target_triangles = 0;  // the screws' 2 mm shafts need every triangle
  const auto others = registration::meshLabelMap(phantom.labels, mesh_options);
  vertebrae.meshes.insert(vertebrae.meshes.end(), others.meshes.begin(), others.meshes.end());
  const Json meshes = writeLabelMeshes(vertebrae, dir, options.format, text);

  Json manifest;
  manifest["name"] = "MR-SNS cervical phantom";
  manifest["generator"] = "mrsns-cli make-phantom (mrsns::registration::generateCervicalPhantom)";
  std::ostringstream command;
  command << "mrsns-cli make-phantom --output " << options.output << " --spacing " << options.spacing_mm << " --seed "
          << options.seed << " --noise " << options.noise_hu;
  manifest["command"] = command.str();
  manifest["frame"] = "CT";
  manifest["coordinates"] = "LPS mm";
  manifest["spacing_mm"] = options.spacing_mm;
  manifest["seed"] = options.seed;
  manifest["noise_sigma_hu"] = phantom.noise_sigma_hu;
  manifest["size"] = Json::array({phantom.ct.size[0], phantom.ct.size[1], phantom.ct.size[2]});
  manifest["origin"] = vector3Json(phantom.ct.origin);
  using D = registration::PhantomDensities;
  manifest["densities_hu"] = Json{{"air", D::air},
                                  {"soft_tissue", D::soft_tissue},
                                  {"cancellous_bone", D::cancellous_bone},
                                  {"cortical_bone", D::cortical_bone},
                                  {"cortex_thickness_mm", D::cortex_thickness_mm},
                                  {"vessel_lumen", D::vessel_lumen},
                                  {"vessel_wall", D::vessel_wall},
                                  {"titanium", D::titanium}};
  Json labels = Json::object();
  for (const auto& [value, name] : phantom.label_names) labels[std::to_string(value)] = name;
  manifest["labels"] = labels;
  Json vertebra_json = Json::array();
  for (const auto& v : phantom.vertebrae) {
    vertebra_json.push_back(Json{{"label", v.label},
                                 {"name", v.name},
                                 {"body_center", vector3Json(v.body_center)},
                                 {"rotation", matrixJson(v.rotation)}});
  }
  manifest["vertebrae"] = vertebra_json;
  Json screws = Json::array();
  for (const auto& s : phantom.screws) {
    screws.push_back(Json{{"label", s.label},
                          {"vertebra", s.vertebra},
                          {"bone_entry", vector3Json(s.bone_entry)},
                          {"tip", vector3Json(s.tip)},
                          {"head", vector3Json(s.head)},
                          {"axis", vector3Json(s.axis)},
                          {"shaft_diameter_mm", s.shaft_diameter_mm},
                          {"head_diameter_mm", s.head_diameter_mm},
                          {"length_mm", s.length_mm}});
  }
  manifest["fiducial_screws"] = screws;
  Json paths = Json::array();
  for (const auto& p : phantom.screw_paths) {
    paths.push_back(Json{{"name", p.name},
                         {"vertebra", p.vertebra},
                         {"entry", vector3Json(p.entry)},
                         {"target", vector3Json(p.target)},
                         {"diameter_mm", p.diameter_mm},
                         {"length_mm", p.effectiveLength()}});
  }
  manifest["screw_paths"] = paths;
  manifest["vessel"] = Json{{"center", vector3Json(phantom.vessel_center)},
                            {"axis", vector3Json(Eigen::Vector3d::UnitZ())},
                            {"lumen_radius_mm", phantom.vessel_lumen_radius_mm},
                            {"outer_radius_mm", phantom.vessel_outer_radius_mm}};
  manifest["files"] = Json{{"ct", ct_file.filename().string()},
                           {"labels", labels_file.filename().string()},
                           {"fiducials_truth", fiducials_file.filename().string()},
                           {"screw_paths", paths_file.filename().string()}};
  Json mesh_files = Json::array();
  for (const auto& m : meshes) {
    mesh_files.push_back(Json{{"label", m["label"]},
                              {"name", m["name"]},
                              {"file", std::filesystem::path(m["file"].get<std::string>()).filename().string()}});
  }
  manifest["files"]["meshes"] = mesh_files;
  const auto manifest_file = dir / "phantom.json";
  {
    std::ofstream out(manifest_file);
    out << manifest.dump(2) << "\n";
    if (!out) throw FileError("cannot write '" + manifest_file.string() + "' (check the folder is writable)");
  }

  Report report;
  report.json["verb"] = "make-phantom";
  report.json["output"] = options.output;
  report.json["spacing_mm"] = options.spacing_mm;
  report.json["seed"] = options.seed;
  report.json["noise_sigma_hu"] = options.noise_hu;
  report.json["size"] = manifest["size"];
  report.json["generate_seconds"] = generate_s;
  report.json["ct"] = ct_file.string();
  report.json["labels"] = labels_file.string();
  report.json["fiducials_truth"] = fiducials_file.string();
  report.json["screw_paths"] = paths_file.string();
  report.json["manifest"] = manifest_file.string();
  report.json["meshes"] = meshes;
  std::ostringstream s;
  s << "Cervical phantom " << phantom.ct.size[0] << "x" << phantom.ct.size[1] << "x" << phantom.ct.size[2] << " at "
    << options.spacing_mm << " mm (seed " << options.seed << ", noise " << options.noise_hu << " HU) in " << generate_s
    << " s\n  " << ct_file.string() << "\n  " << labels_file.string() << "\n  " << fiducials_file.string() << " ("
    << phantom.fiducials_truth.size() << " screw entry points)\n  " << paths_file.string() << " ("
    << phantom.screw_paths.size() << " pedicle screw paths)\n  " << manifest_file.string() << "\n";
  report.text = s.str() + text;
  return report;
}

}  // namespace

void registerMakePhantomVerb(CLI::App& app, GlobalOptions& options, VerbList& verbs) {
  auto opts = std::make_shared<MakePhantomOptions>();
  auto* sub = app.add_subcommand(
      "make-phantom",
      "Writes the bundled cervical phantom: CT-like volume (C3-C7, soft tissue, carotid-like vessel, titanium "
      "fiducial screws), label map, meshes, fiducial ground truth, planned C5/C6 pedicle screw paths, manifest");
  sub->add_option("--output", opts->output, "output folder")->required();
  sub->add_option("--spacing", opts->spacing_mm, "isotropic voxel size (mm)")
      ->check(CLI::Range(0.2, 3.0))
      ->capture_default_str();
  sub->add_option("--seed", opts->seed, "noise seed")->capture_default_str();
  sub->add_option("--noise", opts->noise_hu, "Gaussian noise sigma (HU)")
      ->check(CLI::Range(0.0, 500.0))
      ->capture_default_str();
  sub->add_option("--target-triangles", opts->target_triangles,
                  "decimate each vertebra mesh to at most N triangles (0 = no)")
      ->capture_default_str();
  sub->add_option("--format", opts->format, "mesh file format")
      ->check(CLI::IsMember({"stl", "vtp", "ply", "obj", "vtk"}))
      ->capture_default_str();
  addJsonFlag(*sub, options);
  verbs.emplace_back(sub, [opts] { return run(*opts); });
}

}  // namespace mrsns::cli
