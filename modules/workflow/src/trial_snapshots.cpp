// PNG snapshots of a trial session through the rendering module: the
// registered cervical phantom with its planned screw paths, the deformed soft
// tissue coloured by posterior uncertainty, achieved vs planned placement.
#include <cstdlib>
#include <fstream>
#include <random>

#include "mrsns/core/log.h"
#include "mrsns/deformation/model_building.h"
#include "mrsns/deformation/posterior.h"
#include "mrsns/deformation/vessel_phantom.h"
#include "mrsns/core/mesh_ops.h"
#include "mrsns/io/mesh_io.h"
#include "mrsns/registration/label_meshing.h"
#include "mrsns/registration/phantom_cervical.h"
#include "mrsns/rendering/scene.h"
#include "mrsns/workflow/trial.h"
#include "step_internal.h"

namespace mrsns::workflow {

namespace {

using detail::Json;

constexpr int kWidth = 960;
constexpr int kHeight = 720;
const Eigen::Vector3d kBone(0.93, 0.89, 0.78);
const Eigen::Vector3d kPlanned(0.1, 0.75, 0.2);
const Eigen::Vector3d kAchieved(0.9, 0.15, 0.1);

Eigen::Vector3d vec(const Json& j) {
  return {j[0].get<double>(), j[1].get<double>(), j[2].get<double>()};
}


// The session's bone models in one mesh (CT mm); empty when it has none.
TriangleMesh sessionBone(const Session& session) {
  std::vector<TriangleMesh> meshes;
  for (const auto& m : session.models(ModelRole::Bone)) meshes.push_back(io::readMesh(session.resolve(m.file)));
  if (meshes.empty()) return {};
  TriangleMesh bone = mergeMeshes(meshes);
  bone.frame = "CT";
  return bone;
}

// Screws enter posteriorly (+y in LPS): look from behind and above, superior (+z) up.
void posteriorCamera(rendering::Scene& scene, const Eigen::Vector3d& centre_ct, const Eigen::Isometry3d& world_T_ct,
                     double distance_mm) {
  const Eigen::Vector3d eye_ct = centre_ct + distance_mm * Eigen::Vector3d(0.35, 1.0, 0.45).normalized();
  scene.setCamera(world_T_ct * eye_ct, world_T_ct * centre_ct, world_T_ct.linear() * Eigen::Vector3d::UnitZ());
}

std::string registeredPhantom(const std::filesystem::path& folder, const Eigen::Isometry3d& patient_T_ct,
                              const std::vector<PlannedScrew>& plans, const TriangleMesh& bone) {
  rendering::Scene scene;
  scene.setBackground({0.12, 0.14, 0.18});
  // Translucent bone: the planned paths run inside it.
  scene.setMesh("vertebrae", bone, kBone, 0.5);
  scene.setPose("vertebrae", patient_T_ct);
  Eigen::Vector3d centre = Eigen::Vector3d::Zero();
  int n = 0;
  for (const auto& path : plans) {
    const Eigen::Vector3d entry = path.entry, target = path.target;
    scene.setScrewPath(path.name, patient_T_ct * entry, patient_T_ct * target, path.diameter_mm, kPlanned);
    centre += entry;
    ++n;
  }
  posteriorCamera(scene, n > 0 ? Eigen::Vector3d(centre / n) : Eigen::Vector3d(bone.vertices.colwise().mean()),
                  patient_T_ct, 170.0);
  const std::string name = "registered_phantom.png";
  rendering::snapshotPng(scene, folder / name, kWidth, kHeight);
  return name;
}

std::string placement(const std::filesystem::path& folder, const std::vector<PlannedScrew>& plans, const Json& placed,
                      const TriangleMesh& bone) {
  rendering::Scene scene;
  scene.setBackground({0.12, 0.14, 0.18});
  scene.setMesh("vertebrae", bone, kBone, 0.35);
  Eigen::Vector3d centre = Eigen::Vector3d::Zero();
  int n = 0;
  // Sub-millimetre deviations vanish inside a 3.5 mm screw: both axes are
  // also drawn 25 mm out of the entry, where an angle deviation shows.
  constexpr double kExtension = 25.0;
  for (const auto& path : plans) {
    const auto& name = path.name;
    const Eigen::Vector3d entry = path.entry, target = path.target;
    scene.setScrewPath("planned " + name, entry, target, path.diameter_mm, kPlanned);
    scene.setLine("planned axis " + name, entry - kExtension * (target - entry).normalized(), entry, kPlanned);
    centre += entry;
    ++n;
  }
  for (const auto& path : placed["paths"]) {
    if (!path.contains("achieved_entry_ct")) continue;
    const Eigen::Vector3d entry = vec(path["achieved_entry_ct"]), target = vec(path["achieved_target_ct"]);
    scene.setScrewPath("achieved " + path["name"].get<std::string>(),
                       entry - kExtension * (target - entry).normalized(), target, 1.2, kAchieved);
  }
  posteriorCamera(scene, n > 0 ? Eigen::Vector3d(centre / n) : Eigen::Vector3d(bone.vertices.colwise().mean()),
                  Eigen::Isometry3d::Identity(), 90.0);
  const std::string name = "placement_achieved_vs_planned.png";
  rendering::snapshotPng(scene, folder / name, kWidth, kHeight);
  return name;
}

// A posterior shape model of the carotid-like vessel (paper 001 §III.A):
// PCA of 20 stretched shapes, a held-out stretched shape observed only on the
// lower half of the common carotid (where the sweep ran, 0.5 mm RMS noise
// per point, every third vertex): the
// branches beyond the sweep stay uncertain, which the colours show.
std::string softTissue(const std::filesystem::path& folder, std::uint64_t seed) {
  std::mt19937_64 rng(seed * 2654435761ULL + 7);
  const deformation::VesselPhantomOptions vessel;
  std::vector<TriangleMesh> training;
  for (int i = 0; i < 20; ++i)
    training.push_back(deformation::makeVesselPhantom(deformation::randomVesselDeformation(rng)));
  const auto built = deformation::buildShapeModel(training);
  const auto truth = deformation::makeVesselPhantom(deformation::randomVesselDeformation(rng));
  std::normal_distribution<double> noise(0.0, 0.5 / std::sqrt(3.0));
  std::vector<deformation::ModelPointObservation> observations;
  for (Eigen::Index v = 0; v < truth.vertices.rows(); v += 3) {
    if (truth.vertices(v, 2) > 0.5 * vessel.cca_length_mm) continue;
    const Eigen::Vector3d p = truth.vertices.row(v).transpose() + Eigen::Vector3d(noise(rng), noise(rng), noise(rng));
    observations.push_back(deformation::ModelPointObservation::atVertex(static_cast<std::int32_t>(v), p));
  }
  const auto posterior = deformation::computePosterior(built.model, observations);
  TriangleMesh shape = built.model.reference;
  std::vector<double> sd(static_cast<std::size_t>(built.model.pointCount()));
  double hi = 0.0, lo = 1e9;
  for (Eigen::Index v = 0; v < built.model.pointCount(); ++v) {
    shape.vertices.row(v) = posterior.mean.segment<3>(3 * v).transpose();
    sd[static_cast<std::size_t>(v)] =
        std::sqrt(deformation::posteriorVertexCovariance(built.model, posterior, v).trace());
    hi = std::max(hi, sd[static_cast<std::size_t>(v)]);
    lo = std::min(lo, sd[static_cast<std::size_t>(v)]);
  }
  rendering::Scene scene;
  scene.setBackground({0.12, 0.14, 0.18});
  scene.setMesh("posterior", shape, {0.8, 0.3, 0.3}, 1.0);
  scene.setMeshScalars("posterior", sd, lo, std::max(hi, lo + 1e-3), "Posterior SD (mm)");
  scene.resetCamera();
  const std::string name = "soft_tissue_posterior_uncertainty.png";
  rendering::snapshotPng(scene, folder / name, kWidth, kHeight);
  return name;
}

}  // namespace

std::vector<std::string> writeTrialSnapshots(const std::filesystem::path& folder, const Session& session) {
  const char* display = std::getenv("DISPLAY");
  if (display == nullptr || *display == '\0') {
    throw UnsupportedError(
        "no X display (DISPLAY is not set), so no PNG snapshots: run the trial under "
        "'xvfb-run -a' to get them");
  }
  std::vector<std::string> images;
  const Json reg = session.step("registration");
  // Where the drill truly went is the room's scorer's (the trial keeps its report beside the truth).
  Json placed;
  try {
    std::ifstream in(folder / "room" / "score.json");
    if (in) placed = Json::parse(in).at("scored").at("robot_placement");
  } catch (const Json::exception&) {
    placed = Json();
  }
  const bool have_registration = !reg.is_null() && reg.value("status", "") == "ok";
  const auto patient_T_ct = session.transform("CTToPatient");
  const TriangleMesh bone = sessionBone(session);
  if (have_registration && patient_T_ct && !bone.empty()) {
    Eigen::Isometry3d t = Eigen::Isometry3d::Identity();
    t.matrix() = patient_T_ct->matrix;
    const auto plans = session.plans();
    images.push_back(registeredPhantom(folder, t, plans, bone));
    if (placed.is_object()) images.push_back(placement(folder, plans, placed, bone));
  } else {
    logger()->warn("trial snapshots: no registration of the session's bone models, no phantom or placement snapshot");
  }
  const Json reg_params = have_registration ? reg.value("params", Json::object()) : Json::object();
  images.push_back(softTissue(folder, reg_params.value("seed", 1)));
  return images;
}

}  // namespace mrsns::workflow
