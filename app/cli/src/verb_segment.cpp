// `mrsns-cli segment IMAGE --output DIR`: bone from a CT (threshold, clean-up,
// components) with its mesh, or one mesh per label of a label map.
#include <algorithm>
#include <filesystem>
#include <sstream>

#include "cli_context.h"
#include "mrsns/core/error.h"
#include "mrsns/io/image_io.h"
#include "mrsns/registration/ct_bone_segmentation.h"
#include "mrsns/registration/label_meshing.h"
#include "segment_output.h"

namespace mrsns::cli {
namespace {

struct SegmentOptions {
  std::string image;
  std::string output;
  std::string labels;
  double threshold_hu = 250.0;
  std::size_t keep_largest = 0;
  double min_component_ml = 0.1;
  std::size_t target_triangles = 0;
  int smoothing = 15;
  std::string scheme = "auto";
  std::string format = "stl";
};

/// A label map is integer-valued, non-negative and has few distinct values;
/// a CT has air below zero and thousands of values.
bool looksLikeLabelMap(const ImageVolume& image) {
  const auto stats = io::labelStatistics(image, 256);
  return stats && !stats->empty() && stats->front().value >= 0;
}

registration::LabelMeshOptions meshOptions(const SegmentOptions& options) {
  registration::LabelMeshOptions mesh;
  mesh.smoothing_iterations = options.smoothing;
  mesh.target_triangles = options.target_triangles;
  mesh.scheme = registration::labelSchemeFromName(options.scheme);
  return mesh;
}

Report run(const SegmentOptions& options) {
  const std::filesystem::path dir(options.output);
  std::error_code ec;
  std::filesystem::create_directories(dir, ec);
  if (ec || !std::filesystem::is_directory(dir)) {
    throw FileError("cannot create the output folder '" + options.output + "': " + ec.message());
  }
  Report report;
  report.json["verb"] = "segment";
  report.json["input"] = options.image;
  report.json["output"] = options.output;
  std::string text;

  ImageVolume label_map;
  std::string mode;
  auto mesh_options = meshOptions(options);
  if (!options.labels.empty()) {
    label_map = io::readImage(options.labels);
    mode = "labels";
    report.json["labels"] = options.labels;
  } else {
    ImageVolume image = io::readImage(options.image);
    if (looksLikeLabelMap(image)) {
      label_map = std::move(image);
      mode = "labels";
    } else {
      mode = "bone";
      registration::BoneSegmentationOptions bone_options;
      bone_options.lower_hu = options.threshold_hu;
      bone_options.keep_largest = options.keep_largest;
      bone_options.min_component_ml = options.min_component_ml;
      const auto bone = registration::segmentBone(image, bone_options);
      const auto label_file = dir / "bone_labels.nrrd";
      io::writeImage(bone.labels, label_file);
      Json components = Json::array();
      for (const auto& c : bone.components) {
        components.push_back(Json{{"label", c.label}, {"voxels", c.voxels}, {"volume_ml", c.volume_ml}});
      }
      report.json["bone"] = Json{{"threshold_hu", options.threshold_hu},
                                 {"voxels_above_threshold", bone.voxels_above_threshold},
                                 {"bone_voxels", bone.bone_voxels},
                                 {"volume_ml", bone.volume_ml},
                                 {"components_found", bone.components_found},
                                 {"components_kept", bone.components.size()},
                                 {"components", components},
                                 {"label_map", label_file.string()}};
      std::ostringstream s;
      s << "Bone above " << options.threshold_hu << " HU: " << bone.volume_ml << " ml in " << bone.components.size()
        << " components (of " << bone.components_found << ") -> " << label_file.string() << "\n";
      text += s.str();
      // One surface for all bone: the components are pieces of one skeleton.
      label_map = registration::labelMask(bone.labels);
      mesh_options.scheme = registration::LabelScheme::Generic;
      mesh_options.names[1] = "bone";
    }
  }
  report.json["mode"] = mode;
  const auto meshes = registration::meshLabelMap(label_map, mesh_options);
  report.json["label_scheme"] = registration::labelSchemeName(meshes.scheme);
  report.json["smoothing_iterations"] = options.smoothing;
  report.json["target_triangles"] = options.target_triangles;
  report.json["meshes"] = writeLabelMeshes(meshes, dir, options.format, text);
  report.text = (mode == "labels" ? "Meshes of " + std::to_string(meshes.meshes.size()) + " labels (" +
                                        registration::labelSchemeName(meshes.scheme) + " names)\n"
                                  : std::string()) +
                text;
  return report;
}

}  // namespace

void registerSegmentVerb(CLI::App& app, GlobalOptions& options, VerbList& verbs) {
  auto opts = std::make_shared<SegmentOptions>();
  auto* sub = app.add_subcommand(
      "segment",
      "Patient models from CT: bone from a CT in HU (threshold, clean-up, connected components) as a label map and "
      "a mesh, or one mesh per label of a label map (given with --labels or as IMAGE), named after VerSe or "
      "TotalSegmentator labels");
  sub->add_option("IMAGE", opts->image, "CT (NIfTI, NRRD, MetaImage, DICOM) or integer label map")->required();
  sub->add_option("--output", opts->output, "folder for bone_labels.nrrd and the meshes")->required();
  sub->add_option("--labels", opts->labels, "label map to mesh instead of segmenting IMAGE");
  sub->add_option("--threshold", opts->threshold_hu, "lowest bone HU")->capture_default_str();
  sub->add_option("--keep-largest", opts->keep_largest, "keep only the N largest bone components (0 = all)")
      ->capture_default_str();
  sub->add_option("--min-component-ml", opts->min_component_ml, "drop bone components smaller than this (ml)")
      ->capture_default_str();
  sub->add_option("--target-triangles", opts->target_triangles, "decimate each mesh to at most N triangles (0 = no)")
      ->capture_default_str();
  sub->add_option("--smoothing", opts->smoothing, "windowed-sinc smoothing iterations (0 = none)")
      ->check(CLI::Range(0, 500))
      ->capture_default_str();
  sub->add_option("--scheme", opts->scheme, "label names: auto, verse, totalsegmentator, generic")
      ->check(CLI::IsMember({"auto", "verse", "totalsegmentator", "generic"}))
      ->capture_default_str();
  sub->add_option("--format", opts->format, "mesh file format")
      ->check(CLI::IsMember({"stl", "vtp", "ply", "obj", "vtk"}))
      ->capture_default_str();
  addJsonFlag(*sub, options);
  verbs.emplace_back(sub, [opts] { return run(*opts); });
}

}  // namespace mrsns::cli
