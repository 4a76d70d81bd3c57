// Patient registration on the generated cervical phantom: stylus landmarks
// on the fiducial screws (paired points), then points digitised on the
// posterior bone surface (ICP), against a simulated patient pose.
#include <algorithm>
#include <array>
#include <cmath>
#include <filesystem>
#include <sstream>

#include "mrsns/io/mesh_io.h"
#include "mrsns/registration/label_meshing.h"
#include "mrsns/registration/paired_point.h"
#include "mrsns/registration/phantom_cervical.h"
#include "mrsns/registration/surface_registration.h"
#include "simulation.h"
#include "step_internal.h"

namespace mrsns::workflow::detail {

namespace {

/// A uint8 label map sampled from `image` on the voxel block [lo, hi) every
/// `stride` voxels (block centres), label 1 where `inside(value)`. Meshing a
/// crop or a coarser grid keeps the context models (vessel, neck outline)
/// from costing more than the registration itself.
template <typename Inside>
ImageVolume sampledMask(const ImageVolume& image, std::array<int, 3> lo, std::array<int, 3> hi, int stride,
                        Inside inside) {
  ImageVolume mask;
  mask.pixel_type = PixelType::UInt8;
  mask.direction = image.direction;
  mask.frame = image.frame;
  mask.spacing = image.spacing * stride;
  for (int a = 0; a < 3; ++a) {
    lo[a] = std::clamp(lo[a], 0, image.size[a] - 1);
    hi[a] = std::clamp(hi[a], lo[a] + 1, image.size[a]);
    mask.size[a] = std::max(1, (hi[a] - lo[a]) / stride);
  }
  const double half = 0.5 * (stride - 1);
  mask.origin = image.indexToPhysical(Eigen::Vector3d(lo[0] + half, lo[1] + half, lo[2] + half));
  mask.data.assign(mask.voxelCount(), std::byte{0});
  const int c = stride / 2;
  for (int k = 0; k < mask.size[2]; ++k) {
    for (int j = 0; j < mask.size[1]; ++j) {
      for (int i = 0; i < mask.size[0]; ++i) {
        const double v = image.valueAtIndex(
            image.linearIndex(lo[0] + i * stride + c, lo[1] + j * stride + c, lo[2] + k * stride + c));
        if (inside(v)) mask.data[mask.linearIndex(i, j, k)] = std::byte{1};
      }
    }
  }
  return mask;
}

/// Writes the phantom's models in CT mm (the frame of figures.paths, which
/// is where the GUI draws the planned screws), so the session shows them;
/// figures.transforms.CTToPatient places them in the patient frame.
Json writePhantomModels(Session& session, const registration::CervicalPhantom& phantom,
                        const registration::LabelMeshingResult& bone_meshes, std::vector<std::string>& outputs) {
  std::filesystem::create_directories(session.resolve("registration/models"));
  Json models = Json::array();
  const auto write = [&](TriangleMesh mesh, const std::string& file, const std::string& layer) {
    mesh.frame = "CT";
    io::writeMesh(mesh, session.resolve(file));
    outputs.push_back(file);
    models.push_back({{"file", file}, {"layer", layer}, {"frame", "CT"}, {"triangles", mesh.faceCount()}});
  };
  for (const auto& m : bone_meshes.meshes) {
    write(m.mesh, "registration/models/" + m.name + ".vtp", "vertebrae");
  }
  // The vessel is a straight tube along z: mesh the columns around it only.
  const double margin_mm = phantom.vessel_outer_radius_mm + 3.0;
  const Eigen::Vector3d a =
      phantom.labels.physicalToIndex(phantom.vessel_center - Eigen::Vector3d::Constant(margin_mm));
  const Eigen::Vector3d b =
      phantom.labels.physicalToIndex(phantom.vessel_center + Eigen::Vector3d::Constant(margin_mm));
  const auto vessel = sampledMask(
      phantom.labels,
      {static_cast<int>(std::floor(std::min(a.x(), b.x()))), static_cast<int>(std::floor(std::min(a.y(), b.y()))), 0},
      {static_cast<int>(std::ceil(std::max(a.x(), b.x()))) + 1, static_cast<int>(std::ceil(std::max(a.y(), b.y()))) + 1,
       phantom.labels.size[2]},
      1, [](double v) { return static_cast<int>(v) == registration::kPhantomVesselLabel; });
  registration::LabelMeshOptions vessel_options;
  vessel_options.target_triangles = 2000;
  write(registration::meshLabelMap(vessel, vessel_options).meshes.at(0).mesh, "registration/models/vessel.vtp",
        "soft-tissue");
  // The neck outline (denser than halfway from air to soft tissue, the
  // partial-volume boundary) is smooth: a ~3 mm grid is plenty for a
  // translucent context surface.
  const int stride = std::max(1, static_cast<int>(std::lround(3.0 / phantom.ct.spacing.minCoeff())));
  const double threshold = 0.5 * (registration::PhantomDensities::air + registration::PhantomDensities::soft_tissue);
  const auto neck =
      sampledMask(phantom.ct, {0, 0, 0}, phantom.ct.size, stride, [threshold](double v) { return v > threshold; });
  registration::LabelMeshOptions tissue_options;
  tissue_options.target_triangles = 3000;
  write(registration::meshLabelMap(neck, tissue_options).meshes.at(0).mesh, "registration/models/soft_tissue.vtp",
        "soft-tissue");
  return models;
}

}  // namespace

StepResult runRegistration(Session& session, const Json& params, const StepContext& context) {
  const Params p("registration", params,
                 {"seed", "spacing_mm", "landmark_noise_mm", "surface_points", "surface_noise_mm"});
  const auto seed = static_cast<std::uint64_t>(p.integer("seed", 1));
  const double fle = p.number("landmark_noise_mm", 0.5);
  const double surface_noise = p.number("surface_noise_mm", 0.3);
  const int surface_points = p.integer("surface_points", 400);
  if (fle < 0.0 || surface_noise < 0.0 || surface_points < 10) {
    throw InvalidArgumentError("registration: noise must be >= 0 mm and surface_points >= 10");
  }
  registration::PhantomOptions phantom_options;
  phantom_options.spacing_mm = p.number("spacing_mm", 1.2);
  phantom_options.seed = seed;
  context.report(0.05, "generating the cervical phantom CT");
  const auto phantom = registration::generateCervicalPhantom(phantom_options);
  checkCancel(context);
  context.report(0.3, "meshing the vertebrae");
  registration::LabelMeshOptions mesh_options;
  mesh_options.scheme = registration::LabelScheme::Verse;
  mesh_options.target_triangles = 4000;
  const auto meshes = registration::meshLabelMap(phantom.bone_labels, mesh_options);
  TriangleMesh bone;
  for (const auto& m : meshes.meshes) {
    const auto offset = static_cast<std::int32_t>(bone.vertices.rows());
    bone.vertices.conservativeResize(bone.vertices.rows() + m.mesh.vertices.rows(), 3);
    bone.vertices.bottomRows(m.mesh.vertices.rows()) = m.mesh.vertices;
    bone.faces.conservativeResize(bone.faces.rows() + m.mesh.faces.rows(), 3);
    bone.faces.bottomRows(m.mesh.faces.rows()) = m.mesh.faces.array() + offset;
  }
  bone.frame = "CT";
  checkCancel(context);

  // The patient lies somewhere in the tracker's field of view.
  Simulation sim(seed * 7919 + 3);
  const Eigen::Isometry3d patient_T_ct = sim.pose(0.5, Eigen::Vector3d::Zero(), 50.0);

  context.report(0.5, "landmark registration");
  std::vector<Eigen::Vector3d> landmarks_ct, landmarks_patient;
  for (const auto& l : phantom.fiducials_truth.points) {
    landmarks_ct.push_back(l.position);
    landmarks_patient.push_back(patient_T_ct * l.position + sim.noise(fle));
  }
  const auto pp = registration::registerPairedPoints(landmarks_ct, landmarks_patient);
  Eigen::Isometry3d landmark_patient_T_ct = Eigen::Isometry3d::Identity();
  landmark_patient_T_ct.linear() = pp.rotation;
  landmark_patient_T_ct.translation() = pp.translation;
  checkCancel(context);

  context.report(0.6, "surface registration (ICP)");
  // Points a surgeon can reach: the posterior half of the exposed vertebrae.
  std::vector<Eigen::Vector3d> surface_patient;
  std::vector<Eigen::Index> candidates;
  const double y_mid = bone.vertices.col(1).mean();
  for (Eigen::Index i = 0; i < bone.vertices.rows(); ++i) {
    if (bone.vertices(i, 1) > y_mid) candidates.push_back(i);
  }
  std::shuffle(candidates.begin(), candidates.end(), sim.engine());
  for (int i = 0; i < surface_points && i < static_cast<int>(candidates.size()); ++i) {
    const Eigen::Vector3d v = bone.vertices.row(candidates[static_cast<std::size_t>(i)]).transpose();
    surface_patient.push_back(patient_T_ct * v + sim.noise(surface_noise));
  }
  registration::IcpOptions icp_options;
  icp_options.max_correspondence_distance_mm = 5.0;
  const auto icp = registration::registerSurface(surface_patient, bone, landmark_patient_T_ct.inverse(), icp_options);
  const Eigen::Isometry3d icp_patient_T_ct = icp.fixed_T_moving.inverse();
  checkCancel(context);

  // Target registration error at the planned screw entries and targets.
  std::vector<double> tre_landmarks, tre_icp;
  Json targets = Json::array();
  for (const auto& path : phantom.screw_paths) {
    for (const auto& [what, point] : {std::pair{"entry", path.entry}, std::pair{"target", path.target}}) {
      const Eigen::Vector3d truth = patient_T_ct * point;
      tre_landmarks.push_back((landmark_patient_T_ct * point - truth).norm());
      tre_icp.push_back((icp_patient_T_ct * point - truth).norm());
      targets.push_back({{"path", path.name},
                         {"point", what},
                         {"tre_landmarks_mm", tre_landmarks.back()},
                         {"tre_surface_mm", tre_icp.back()},
                         {"tre_predicted_mm", registration::predictTreRms(landmarks_ct, point, fle)}});
    }
  }
  Json paths = Json::array();
  for (const auto& path : phantom.screw_paths) {
    paths.push_back({{"name", path.name},
                     {"entry_ct", {path.entry.x(), path.entry.y(), path.entry.z()}},
                     {"target_ct", {path.target.x(), path.target.y(), path.target.z()}}});
  }
  context.report(0.9, "writing the phantom models");
  std::vector<std::string> outputs;
  const Json models = writePhantomModels(session, phantom, meshes, outputs);
  StepResult result;
  result.outputs = outputs;
  result.ok = icp.converged || icp.rms_mm < 3.0 * surface_noise + 0.5;
  result.figures = {{"landmarks",
                     {{"count", landmarks_ct.size()},
                      {"fre_rms_mm", pp.fre_rms_mm},
                      {"fre_expected_mm", registration::expectedFreRms(static_cast<int>(landmarks_ct.size()), fle)},
                      {"tre", statsJson(tre_landmarks)}}},
                    {"surface",
                     {{"points", surface_patient.size()},
                      {"rms_mm", icp.rms_mm},
                      {"iterations", icp.iterations},
                      {"converged", icp.converged},
                      {"inlier_fraction", icp.inlier_fraction},
                      {"tre", statsJson(tre_icp)}}},
                    {"targets", targets},
                    {"paths", paths},
                    {"models", models},
                    {"noise_model", {{"landmark_fle_rms_mm", fle}, {"surface_noise_rms_mm", surface_noise}}},
                    {"transforms", {{"CTToPatient", matrixJson(icp_patient_T_ct.matrix())}}},
                    {"simulation_truth", {{"CTToPatient", matrixJson(patient_T_ct.matrix())}}}};
  std::ostringstream s;
  s.precision(3);
  s << "landmarks FRE " << pp.fre_rms_mm << " mm, surface RMS " << icp.rms_mm << " mm, TRE at the screw paths "
    << result.figures["surface"]["tre"]["rms"].get<double>() << " mm RMS";
  result.summary = s.str();
  return result;
}

}  // namespace mrsns::workflow::detail
