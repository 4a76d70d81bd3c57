// make-models and import-model: the patient's surface models in the CT's
// frame, from the session's label maps, a bone threshold of its CT, or the
// user's mesh files; each with its role, colour, volume check against its
// voxels and a light copy for the headset.
#include <algorithm>
#include <cctype>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "mrsns/core/error.h"
#include "mrsns/core/parallel.h"
#include "mrsns/core/mesh_ops.h"
#include "mrsns/io/file_names.h"
#include "mrsns/io/mesh_io.h"
#include "mrsns/registration/ct_bone_segmentation.h"
#include "mrsns/registration/label_meshing.h"
#include "mrsns/registration/label_names.h"
#include "patient_data.h"

namespace mrsns::workflow::detail {

namespace fs = std::filesystem;

namespace {

std::string lowerCase(std::string s) {
  for (auto& c : s) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return s;
}

std::vector<std::string> splitList(const std::string& text) {
  std::vector<std::string> out;
  std::string item;
  std::istringstream in(text);
  while (std::getline(in, item, ',')) {
    item.erase(0, item.find_first_not_of(" \t"));
    item.erase(item.find_last_not_of(" \t") + 1);
    if (!item.empty()) out.push_back(item);
  }
  return out;
}

/// The labels `text` names in `map` (values or names, "L1" for "vertebrae_L1"); every label when empty.
std::vector<LabelEntry> chooseLabels(const LabelMapEntry& map, const std::string& text) {
  if (text.empty()) return map.labels;
  std::vector<LabelEntry> chosen;
  for (const auto& token : splitList(text)) {
    const LabelEntry* found = nullptr;
    const bool numeric = token.find_first_not_of("0123456789") == std::string::npos;
    for (const auto& l : map.labels) {
      if (numeric ? std::to_string(l.value) == token
                  : lowerCase(l.name) == lowerCase(token) ||
                        (!vertebraName(token).empty() && vertebraName(token) == vertebraName(l.name))) {
        found = &l;
        break;
      }
    }
    if (found == nullptr) {
      std::string list;
      for (const auto& l : map.labels) list += (list.empty() ? "" : ", ") + l.name + " (" + std::to_string(l.value) + ")";
      throw InvalidArgumentError("make-models: label '" + token + "' has no voxel in label map '" + map.id +
                                 "': it is empty or absent there (the labels present are " + list + ")");
    }
    if (std::none_of(chosen.begin(), chosen.end(), [&](const LabelEntry& c) { return c.value == found->value; })) {
      chosen.push_back(*found);
    }
  }
  return chosen;
}

/// An id for a model from `label_map`'s `label`: its existing model's (re-meshing replaces it), else a free one.
std::string modelIdFor(const Session& session, const std::string& base, const std::string& label_map, int label) {
  for (const auto& m : session.models()) {
    if (m.label_map == label_map && m.label == label && !label_map.empty()) return m.id;
  }
  const auto existing = session.model(base);
  if (!existing) return base;
  return session.freeModelId(base);
}

Json modelFigures(const ModelEntry& m) {
  Json j = {{"id", m.id},
            {"name", m.name},
            {"role", modelRoleName(m.role)},
            {"file", m.file},
            {"triangles", m.triangles},
            {"volume_ml", m.volume_ml}};
  if (!m.hmd_file.empty()) {
    j["hmd_file"] = m.hmd_file;
    j["hmd_triangles"] = m.hmd_triangles;
  }
  if (m.voxel_volume_ml > 0.0) {
    j["voxel_volume_ml"] = m.voxel_volume_ml;
    j["volume_tolerance_ml"] = m.volume_tolerance_ml;
    j["volume_matches_voxels"] = std::abs(m.volume_ml - m.voxel_volume_ml) <= m.volume_tolerance_ml;
  }
  if (!m.vertebra.empty()) j["vertebra"] = m.vertebra;
  return j;
}

std::size_t sizeParam(const Params& p, const std::string& key, int fallback, const std::string& step) {
  const int v = p.integer(key, fallback);
  if (v < 0) throw InvalidArgumentError(step + ": " + key + " must be >= 0 (0 = no limit)");
  return static_cast<std::size_t>(v);
}

}  // namespace

StepResult runMakeModels(Session& session, const Json& params, const StepContext& context) {
  const Params p("make-models", params,
                 {"source", "label_map", "labels", "threshold_hu", "smoothing_iterations", "target_triangles",
                  "hmd_triangles", "role", "name", "keep_largest"});
  const std::string source = p.text("source", session.labelMaps().empty() ? "threshold" : "labels");
  if (source != "labels" && source != "threshold") {
    throw InvalidArgumentError("make-models: source must be labels (from a label map) or threshold (bone from the "
                               "CT's Hounsfield units), not '" + source + "'");
  }
  const int smoothing = p.integer("smoothing_iterations", 15);
  if (smoothing < 0 || smoothing > 200) throw InvalidArgumentError("make-models: smoothing_iterations in 0..200");
  const std::size_t target = sizeParam(p, "target_triangles", 0, "make-models");
  const std::size_t hmd = sizeParam(p, "hmd_triangles", 20000, "make-models");
  if (hmd > 0 && hmd < 100) throw InvalidArgumentError("make-models: hmd_triangles must be 0 (none) or >= 100");
  const bool has_role = p.has("role");
  const ModelRole role_param = has_role ? modelRoleFromName(p.text("role", "")) : ModelRole::Other;

  StepResult result;
  std::vector<ModelEntry> made;
  if (source == "labels") {
    if (p.has("threshold_hu") || p.has("keep_largest")) {
      throw InvalidArgumentError("make-models: threshold_hu and keep_largest are for source=threshold");
    }
    const LabelMapEntry map = sessionLabelMap(session, p.text("label_map", ""), "make-models");
    const auto chosen = chooseLabels(map, p.text("labels", ""));
    context.report(0.05, "reading label map " + map.id);
    const ImageVolume labels = loadSessionLabelMap(session, map);
    checkCancel(context);
    registration::LabelMeshOptions options;
    for (const auto& l : chosen) {
      options.labels.push_back(l.value);
      options.names[l.value] = l.name;
    }
    options.smoothing_iterations = smoothing;
    options.target_triangles = target;
    options.scheme = registration::labelSchemeFromName(map.scheme.empty() ? "auto" : map.scheme);
    options.frame = "CT";
    context.report(0.15, "meshing " + std::to_string(chosen.size()) + " label(s) of " + map.id);
    const auto meshes = registration::meshLabelMap(labels, options);
    checkCancel(context);
    // The entries first (their ids depend on one another's names), then each model's files and headset copy
    // on its own thread: decimating a vertebra for the headset takes a good part of a second.
    std::vector<ModelEntry> entries;
    for (const auto& m : meshes.meshes) {
      ModelEntry e;
      e.vertebra = vertebraName(m.name);
      e.name = e.vertebra.empty() ? m.name : e.vertebra;
      e.id = modelIdFor(session, e.name, map.id, m.label);
      e.role = has_role ? role_param : structureRole(m.name);
      // The label scheme's colour (vertebrae alternate along the spine, arteries red, veins blue), else the role's.
      e.color = (m.color - Eigen::Vector3d::Constant(0.8)).norm() > 1e-9 ? m.color : roleColor(e.role);
      e.opacity = e.role == ModelRole::SoftTissue ? 0.35 : 1.0;
      e.label_map = map.id;
      e.label = m.label;
      e.voxel_volume_ml = m.voxel_volume_ml;
      e.volume_tolerance_ml = m.volume_tolerance_ml;
      e.provenance = madeBy("make-models");
      entries.push_back(std::move(e));
    }
    context.report(0.6, "writing " + std::to_string(entries.size()) + " model(s) and their headset copies");
    std::vector<std::vector<std::string>> outputs(entries.size());
    fs::create_directories(session.resolve("models/hmd"));
    parallelForBlocks(0, entries.size(), [&](std::size_t begin, std::size_t end) {
      for (std::size_t i = begin; i < end; ++i) {
        entries[i] = writeModelFiles(session, meshes.meshes[i].mesh, entries[i], hmd, outputs[i]);
        entries[i].provenance.quality = modelFigures(entries[i]);
      }
    });
    for (std::size_t i = 0; i < entries.size(); ++i) {
      result.outputs.insert(result.outputs.end(), outputs[i].begin(), outputs[i].end());
      made.push_back(entries[i]);
    }
  } else {
    if (p.has("label_map") || p.has("labels")) {
      throw InvalidArgumentError("make-models: label_map and labels are for source=labels");
    }
    const ImageVolume ct = loadSessionCt(session, "make-models");
    checkCancel(context);
    registration::BoneSegmentationOptions options;
    options.lower_hu = p.number("threshold_hu", options.lower_hu);
    const int keep = p.integer("keep_largest", 0);
    if (keep < 0) throw InvalidArgumentError("make-models: keep_largest must be >= 0 (0 = all)");
    options.keep_largest = static_cast<std::size_t>(keep);
    context.report(0.1, "bone above " + std::to_string(static_cast<int>(options.lower_hu)) + " HU");
    const auto bone = registration::segmentBone(ct, options);
    checkCancel(context);
    const ImageVolume mask = registration::labelMask(bone.labels);
    registration::LabelMeshOptions mesh_options;
    mesh_options.smoothing_iterations = smoothing;
    mesh_options.target_triangles = target;
    mesh_options.scheme = registration::LabelScheme::Generic;
    mesh_options.frame = "CT";
    context.report(0.5, "meshing the bone");
    const auto meshes = registration::meshLabelMap(mask, mesh_options);
    const auto& m = meshes.meshes.at(0);
    ModelEntry e;
    e.name = p.text("name", "bone");
    e.id = modelIdFor(session, e.name, "", 0);
    if (const auto old = session.model(e.name); old && std::isfinite(old->threshold_hu)) e.id = old->id;
    e.role = has_role ? role_param : ModelRole::Bone;
    e.color = roleColor(e.role);
    e.threshold_hu = options.lower_hu;
    e.voxel_volume_ml = m.voxel_volume_ml;
    e.volume_tolerance_ml = m.volume_tolerance_ml;
    e.provenance = madeBy("make-models");
    e = writeModelFiles(session, m.mesh, e, hmd, result.outputs);
    e.provenance.quality = modelFigures(e);
    e.provenance.quality["components"] = bone.components.size();
    made.push_back(e);
    result.figures["components"] = bone.components.size();
    result.figures["bone_volume_ml"] = bone.volume_ml;
  }
  session.putModels(made);
  Json list = Json::array();
  std::string names;
  int mismatched = 0;
  for (const auto& m : made) {
    list.push_back(modelFigures(m));
    if (m.voxel_volume_ml > 0.0 && std::abs(m.volume_ml - m.voxel_volume_ml) > m.volume_tolerance_ml) ++mismatched;
    std::ostringstream one;
    one.precision(1);
    one << std::fixed << m.name << " " << m.volume_ml << " ml";
    names += (names.empty() ? "" : ", ") + one.str();
  }
  result.figures["models"] = list;
  result.figures["source"] = source;
  if (mismatched > 0) {
    result.figures["warning"] = std::to_string(mismatched) +
                                " model(s) enclose a volume farther from their voxels' than the voxel size explains "
                                "(thin or fragmented structures: check them on the slices)";
  }
  if (!session.plans().empty()) {
    context.report(0.97, "updating the planned screws' figures");
    result.figures["plan"] = refreshPlanFigures(session);
  }
  result.ok = true;
  result.summary = std::to_string(made.size()) + " model(s): " + names;
  return result;
}

StepResult runImportModel(Session& session, const Json& params, const StepContext& context) {
  const Params p("import-model", params,
                 {"path", "role", "name", "id", "color", "opacity", "hmd_triangles", "coordinate_system"});
  const std::string path = p.text("path", "");
  if (path.empty()) throw InvalidArgumentError("import-model: give path= a mesh (STL, VTP, VTK, OBJ or PLY) in the CT's frame");
  // Without a CT (a phantom's or a device's model for the headset) the mesh is taken in the session's CT frame as
  // given; with one, a mesh that misses the CT is refused as being in another frame.
  const auto ct = session.ct();
  context.report(0.1, "reading " + fs::path(path).filename().string());
  TriangleMesh mesh = io::readMesh(path);
  if (mesh.faceCount() == 0) {
    throw FormatError("import-model: '" + path + "' holds no triangle (points or lines only): give a surface mesh");
  }
  // 3D Slicer writes the coordinate system into a model file's header ("SPACE=RAS" or "SPACE=LPS", Slicer 4.11
  // and later; LPS when absent). MR-SNS is LPS inside.
  std::string space = p.text("coordinate_system", "");
  if (space.empty()) {
    std::ifstream in(path, std::ios::binary);
    std::string head(1024, '\0');
    in.read(head.data(), static_cast<std::streamsize>(head.size()));
    head.resize(static_cast<std::size_t>(in.gcount()));
    space = head.find("SPACE=RAS") != std::string::npos ? "RAS" : "LPS";
  }
  if (space != "LPS" && space != "RAS") throw InvalidArgumentError("import-model: coordinate_system is LPS or RAS");
  if (space == "RAS") {
    mesh.vertices.col(0) *= -1.0;
    mesh.vertices.col(1) *= -1.0;
    if (mesh.normals.rows() > 0) {
      mesh.normals.col(0) *= -1.0;
      mesh.normals.col(1) *= -1.0;
    }
  }
  const Eigen::AlignedBox3d mesh_box = boundingBox(mesh);
  const Eigen::AlignedBox3d ct_box = ct ? ctBounds(*ct) : mesh_box;
  if (!ct_box.intersects(mesh_box)) {
    std::ostringstream out;
    out.precision(1);
    out << std::fixed << "import-model: '" << path << "' lies " << ct_box.exteriorDistance(mesh_box.center())
        << " mm outside the session's CT: it is in another frame (a model exported in RAS without a SPACE header "
           "needs coordinate_system=RAS; a model of another patient does not belong here)";
    throw FormatError(out.str());
  }
  ModelEntry e;
  const std::string stem = fs::path(path).stem().string();
  e.name = p.text("name", stem);
  e.vertebra = vertebraName(e.name);
  e.id = p.text("id", session.model(e.name) ? session.freeModelId(e.name) : e.name);
  e.role = p.has("role") ? modelRoleFromName(p.text("role", "")) : structureRole(e.name);
  e.color = roleColor(e.role);
  if (p.has("color")) {
    const Eigen::Vector3d c = pointParam(params, "color", "import-model");
    if ((c.array() < 0.0).any() || (c.array() > 1.0).any()) {
      throw InvalidArgumentError("import-model: color is \"r,g,b\" with each in [0, 1]");
    }
    e.color = c;
  }
  e.opacity = p.number("opacity", e.role == ModelRole::SoftTissue ? 0.35 : 1.0);
  if (!(e.opacity >= 0.0 && e.opacity <= 1.0)) throw InvalidArgumentError("import-model: opacity in [0, 1]");
  e.provenance = madeBy("import-model", fs::absolute(path).string());
  StepResult result;
  const std::size_t hmd = sizeParam(p, "hmd_triangles", 20000, "import-model");
  e = writeModelFiles(session, mesh, e, hmd, result.outputs);
  e.provenance.quality = modelFigures(e);
  e.provenance.quality["coordinate_system"] = space;
  session.putModel(e);
  result.figures["models"] = Json::array({modelFigures(e)});
  result.figures["coordinate_system"] = space;
  if (!ct) result.figures["warning"] = "the session has no CT: the model is placed in its frame as given";
  if (!session.plans().empty()) result.figures["plan"] = refreshPlanFigures(session);
  result.ok = true;
  result.summary = "model " + e.name + " (" + modelRoleName(e.role) + ", " + std::to_string(e.triangles) +
                   " triangles)";
  return result;
}

}  // namespace mrsns::workflow::detail
