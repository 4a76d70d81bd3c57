// `mrsns-cli snapshot --mesh A.stl [--mesh B.vtp ...] [--paths P.mrk.json]
// [--ct CT.nii.gz] --out view.png [--width W --height H]`: renders meshes
// (and planned screw paths) offscreen to a PNG, and with --ct the axial,
// sagittal and coronal slices through the CT's centre to <out>_slices.png.
#include <chrono>
#include <filesystem>
#include <sstream>

#include "cli_context.h"
#include "mrsns/core/error.h"
#include "mrsns/io/image_io.h"
#include "mrsns/io/mesh_io.h"
#include "mrsns/io/screw_path_io.h"
#include "mrsns/rendering/scene.h"
#include "mrsns/rendering/slice_views.h"

namespace mrsns::cli {
namespace {

struct SnapshotOptions {
  std::vector<std::string> meshes;
  std::string paths;
  std::string ct;
  std::string out;
  int width = 1280;
  int height = 800;
  double window = 400.0;
  double level = 40.0;
};

// Distinguishable colours for successive meshes: bone first.
Eigen::Vector3d paletteColor(std::size_t i) {
  static const Eigen::Vector3d palette[] = {{0.93, 0.88, 0.75}, {0.85, 0.45, 0.40}, {0.45, 0.65, 0.90},
                                            {0.55, 0.80, 0.50}, {0.90, 0.75, 0.35}, {0.70, 0.55, 0.85}};
  return palette[i % (sizeof palette / sizeof palette[0])];
}

Json vec3(const Eigen::Vector3d& v) {
  return Json::array({v.x(), v.y(), v.z()});
}

Report run(const SnapshotOptions& options) {
  const std::filesystem::path out(options.out);
  Report report;
  report.json["verb"] = "snapshot";
  std::ostringstream text;
  const auto start = std::chrono::steady_clock::now();

  if (!options.meshes.empty()) {
    rendering::Scene scene;
    Json meshes = Json::array();
    std::size_t triangles = 0;
    for (std::size_t i = 0; i < options.meshes.size(); ++i) {
      const std::filesystem::path file(options.meshes[i]);
      if (!std::filesystem::exists(file))
        throw FileError("mesh '" + file.string() + "' does not exist: check the path");
      const TriangleMesh mesh = io::readMesh(file);
      if (mesh.empty()) throw FormatError("mesh '" + file.string() + "' has no triangles: nothing to draw");
      const Eigen::Vector3d color = paletteColor(i);
      scene.setMesh(file.filename().string() + "#" + std::to_string(i), mesh, color);
      triangles += static_cast<std::size_t>(mesh.faceCount());
      meshes.push_back(Json{{"file", file.string()},
                            {"vertices", mesh.vertexCount()},
                            {"triangles", mesh.faceCount()},
                            {"color", vec3(color)}});
      text << "mesh " << file.string() << ": " << mesh.faceCount() << " triangles\n";
    }
    Json paths = Json::array();
    if (!options.paths.empty()) {
      for (const auto& line : io::readMarkupsLines(options.paths)) {
        scene.setScrewPath("path " + line.name, line.start, line.end, 3.5, Eigen::Vector3d(0.1, 0.8, 0.3));
        paths.push_back(line.name);
      }
    }
    scene.resetCamera();
    rendering::snapshotPng(scene, out, options.width, options.height);
    report.json["png"] = out.string();
    report.json["meshes"] = meshes;
    report.json["screw_paths"] = paths;
    report.json["triangles"] = triangles;
    text << "wrote " << out.string() << " (" << options.width << "x" << options.height << ")\n";
  }

  if (!options.ct.empty()) {
    const ImageVolume ct = io::readImage(options.ct);
    rendering::SliceViews views;
    views.setVolume(ct);
    views.setWindowLevel(options.window, options.level);
    const std::filesystem::path slices =
        options.meshes.empty() ? out : out.parent_path() / (out.stem().string() + "_slices" + out.extension().string());
    rendering::snapshotSlicesPng(views, slices, options.width, options.height);
    report.json["slices_png"] = slices.string();
    report.json["ct"] = Json{{"file", options.ct},
                             {"size", Json::array({ct.size[0], ct.size[1], ct.size[2]})},
                             {"cursor", vec3(views.cursor())},
                             {"window", options.window},
                             {"level", options.level}};
    text << "wrote " << slices.string() << " (axial, sagittal, coronal through " << views.cursor().transpose() << ")\n";
  }
  report.json["width"] = options.width;
  report.json["height"] = options.height;
  report.json["seconds"] = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  report.text = text.str();
  return report;
}

}  // namespace

void registerSnapshotVerb(CLI::App& app, GlobalOptions& options, VerbList& verbs) {
  auto* sub = app.add_subcommand("snapshot",
                                 "Render meshes (and planned screw paths) offscreen to a PNG; with --ct also the "
                                 "axial, sagittal and coronal CT slices (needs an X display: xvfb-run -a)");
  auto opts = std::make_shared<SnapshotOptions>();
  sub->add_option("--mesh", opts->meshes, "mesh file (STL, VTP, VTK, OBJ, PLY); repeat for several")
      ->check(CLI::ExistingFile);
  sub->add_option("--paths", opts->paths, "planned screw paths (Slicer markups lines .mrk.json), drawn as tubes")
      ->check(CLI::ExistingFile);
  sub->add_option("--ct", opts->ct, "CT volume (NRRD, NIfTI, MetaImage, DICOM folder): slice views")
      ->check(CLI::ExistingPath);
  sub->add_option("--out", opts->out, "output PNG")->required();
  sub->add_option("--width", opts->width, "image width (px)")->check(CLI::Range(16, 8192))->capture_default_str();
  sub->add_option("--height", opts->height, "image height (px)")->check(CLI::Range(16, 8192))->capture_default_str();
  sub->add_option("--window", opts->window, "CT window width (HU)")->capture_default_str();
  sub->add_option("--level", opts->level, "CT window level (HU)")->capture_default_str();
  addJsonFlag(*sub, options);
  sub->callback([opts] {
    if (opts->meshes.empty() && opts->ct.empty()) {
      throw CLI::ValidationError("snapshot", "give at least one --mesh or a --ct");
    }
    if (!opts->paths.empty() && opts->meshes.empty()) {
      throw CLI::ValidationError("--paths", "screw paths are drawn in the mesh view: give --mesh too");
    }
  });
  verbs.emplace_back(sub, [opts]() { return run(*opts); });
}

}  // namespace mrsns::cli
