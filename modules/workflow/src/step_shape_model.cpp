// shape-model: the statistical shape model of the critical soft tissue
// (statismo HDF5, paper 001 §II.B), imported or built from meshes in
// correspondence, placed in the CT and checked to lie in it; its mean shape
// becomes a soft-tissue model of the session.
#include <algorithm>
#include <filesystem>
#include <sstream>

#include "mrsns/core/error.h"
#include "mrsns/core/mesh_ops.h"
#include "mrsns/deformation/model_building.h"
#include "mrsns/io/file_names.h"
#include "mrsns/io/mesh_io.h"
#include "mrsns/io/statismo_io.h"
#include "mrsns/io/transform_io.h"
#include "patient_data.h"

namespace mrsns::workflow::detail {

namespace fs = std::filesystem;

namespace {

bool isMeshFile(const fs::path& p) {
  const std::string name = io::lowerFileName(p);
  for (const char* ext : {".stl", ".vtp", ".vtk", ".obj", ".ply"}) {
    if (io::endsWith(name, ext)) return true;
  }
  return false;
}

TriangleMesh meanMesh(const ShapeModel& model) {
  TriangleMesh mesh = model.reference;
  mesh.vertices = Eigen::Map<const PointsN3>(model.mean.data(), model.pointCount(), 3);
  mesh.normals.resize(0, 3);
  mesh.colors.resize(0, 3);
  mesh.normals = vertexNormals(mesh);
  return mesh;
}

}  // namespace

StepResult runShapeModel(Session& session, const Json& params, const StepContext& context) {
  const Params p("shape-model", params,
                 {"source", "path", "model_to_ct", "transform", "name", "max_modes", "hmd_triangles", "role"});
  const auto ct = session.ct();
  if (!ct) throw InvalidArgumentError("shape-model: import the patient's CT first (import-ct): the model is placed in it");
  const std::string path = p.text("path", "");
  if (path.empty()) {
    throw InvalidArgumentError("shape-model: give path= a statismo model (.h5) with source=file, or a folder of "
                               "meshes in correspondence with source=meshes");
  }
  const std::string source = p.text("source", fs::is_directory(path) ? "meshes" : "file");
  Eigen::Matrix4d ct_T_model = Eigen::Matrix4d::Identity();
  if (p.has("model_to_ct") && p.has("transform")) {
    throw InvalidArgumentError("shape-model: give model_to_ct (16 numbers) or transform (a file), not both");
  }
  if (p.has("model_to_ct")) {
    const Json& m = params.at("model_to_ct");
    ct_T_model = matrixFromJson(m.is_string() ? Json::parse(m.get<std::string>(), nullptr, false) : m,
                                "shape-model model_to_ct");
  } else if (p.has("transform")) {
    ct_T_model = io::readChildToParent(p.text("transform", ""));
  }
  if (!ct_T_model.allFinite() || (ct_T_model.row(3) - Eigen::RowVector4d(0, 0, 0, 1)).norm() > 1e-9) {
    throw InvalidArgumentError("shape-model: model_to_ct is not an affine transform");
  }
  StepResult result;
  ShapeModel model;
  std::string stored;
  fs::create_directories(session.resolve("shape_model"));
  if (source == "file") {
    context.report(0.1, "reading " + fs::path(path).filename().string());
    io::StatismoFileInfo info;
    model = io::readStatismoModel(path, &info);
    stored = freeSessionName(session, "shape_model", fs::path(path).stem().string(), ".h5");
    std::error_code ec;
    fs::copy_file(path, session.resolve(stored), fs::copy_options::overwrite_existing, ec);
    if (ec) throw FileError("shape-model: copying '" + path + "' into the session failed: " + ec.message());
    result.figures["representer"] = info.representer_name;
    result.figures["format_version"] = std::to_string(info.major_version) + "." + std::to_string(info.minor_version);
  } else if (source == "meshes") {
    std::vector<fs::path> files;
    for (const auto& e : fs::directory_iterator(path)) {
      if (e.is_regular_file() && isMeshFile(e.path())) files.push_back(e.path());
    }
    std::sort(files.begin(), files.end());
    if (files.size() < 2) {
      throw InvalidArgumentError("shape-model: '" + path + "' holds " + std::to_string(files.size()) +
                                 " mesh(es): a shape model needs at least 2 examples in correspondence");
    }
    std::vector<TriangleMesh> meshes;
    for (const auto& f : files) meshes.push_back(io::readMesh(f));
    context.report(0.3, "building the model from " + std::to_string(meshes.size()) + " meshes");
    deformation::ShapeModelBuildOptions build;
    build.max_modes = p.integer("max_modes", 0);
    const auto built = deformation::buildShapeModel(meshes, build);
    model = built.model;
    stored = freeSessionName(session, "shape_model", "SoftTissueModel", ".h5");
    io::writeStatismoModel(model, session.resolve(stored));
    result.figures["examples"] = meshes.size();
    result.figures["retained_variance_fraction"] = built.retained_variance_fraction;
  } else {
    throw InvalidArgumentError("shape-model: source must be file (a statismo .h5) or meshes (a folder)");
  }
  result.outputs.push_back(stored);
  checkCancel(context);

  // The model must lie in the CT: a model in another frame would update the wrong tissue silently.
  TriangleMesh mean = meanMesh(model);
  Eigen::Affine3d affine;
  affine.matrix() = ct_T_model;
  for (Eigen::Index v = 0; v < mean.vertices.rows(); ++v) {
    mean.vertices.row(v) = (affine * Eigen::Vector3d(mean.vertices.row(v).transpose())).transpose();
  }
  mean.normals = vertexNormals(mean);
  mean.frame = "CT";
  const Eigen::AlignedBox3d bounds = ctBounds(*ct);
  const Eigen::AlignedBox3d box = boundingBox(mean);
  std::size_t inside = 0;
  for (Eigen::Index v = 0; v < mean.vertices.rows(); ++v) {
    if (bounds.contains(Eigen::Vector3d(mean.vertices.row(v).transpose()))) ++inside;
  }
  const double inside_fraction = static_cast<double>(inside) / static_cast<double>(std::max<Eigen::Index>(1, mean.vertexCount()));
  if (inside_fraction < 0.5) {
    std::ostringstream out;
    out.precision(1);
    out << std::fixed << "shape-model: only " << 100.0 * inside_fraction
        << " % of the model's mean shape lies in the session's CT (its centre is "
        << bounds.exteriorDistance(box.center())
        << " mm outside it): the model is in another frame than the CT; give model_to_ct or transform= its "
           "ModelToCT placement";
    throw FormatError(out.str());
  }
  ShapeModelEntry entry;
  entry.file = stored;
  entry.name = p.text("name", fs::path(path).stem().string());
  entry.role = p.has("role") ? modelRoleFromName(p.text("role", "")) : ModelRole::SoftTissue;
  entry.ct_T_model = ct_T_model;
  entry.components = static_cast<int>(model.modeCount());
  entry.points = static_cast<std::size_t>(model.pointCount());
  entry.provenance = madeBy("shape-model", fs::absolute(path).string());
  ModelEntry m;
  m.id = session.model("soft-tissue-mean") ? "soft-tissue-mean" : session.freeModelId("soft-tissue-mean");
  m.name = entry.name + " (mean)";
  m.role = entry.role;
  m.color = roleColor(m.role);
  m.opacity = m.role == ModelRole::SoftTissue ? 0.35 : 1.0;
  m.provenance = madeBy("shape-model");
  const int hmd = p.integer("hmd_triangles", 0);
  if (hmd < 0) throw InvalidArgumentError("shape-model: hmd_triangles must be >= 0");
  // The headset gets the whole mean: its vertices are what the posterior moves (vertex updates keep the topology).
  m = writeModelFiles(session, mean, m, static_cast<std::size_t>(hmd), result.outputs);
  entry.mean_model = m.id;
  entry.provenance.quality = {{"components", entry.components},
                              {"points", entry.points},
                              {"mean_inside_ct_fraction", inside_fraction}};
  session.putModel(m);
  session.setShapeModel(entry);
  result.figures["components"] = entry.components;
  result.figures["points"] = entry.points;
  result.figures["mean_inside_ct_fraction"] = inside_fraction;
  result.figures["mean_model"] = m.id;
  if (!session.plans().empty()) result.figures["plan"] = refreshPlanFigures(session);
  result.ok = true;
  result.summary = "shape model " + entry.name + ": " + std::to_string(entry.components) + " modes, " +
                   std::to_string(entry.points) + " points";
  return result;
}

}  // namespace mrsns::workflow::detail
