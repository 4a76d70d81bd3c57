// The CT side of a patient registration (see registration_ct.h).
#include "registration_ct.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <deque>
#include <filesystem>

#include "mrsns/core/error.h"
#include "mrsns/io/mesh_io.h"

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

// Writes the phantom's models in CT mm (the frame of figures.paths, which
/// is where the GUI draws the planned screws), so the session shows them;
/// figures.transforms.CTToPatient places them in the patient frame.
}  // namespace

Json writePhantomModels(Session& session, const PreparedCt& ct, std::vector<std::string>& outputs) {
  const auto& phantom = ct.phantom;
  const auto& bone_meshes = ct.bone_meshes;
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


namespace {

// Metal in CT: far above cortical bone (about 1000 HU), titanium is 3000 HU and more.
constexpr double kMetalHu = 2000.0;

/// Connected (26-neighbour) regions of the mask with at least `min_voxels`.
int countComponents(const ImageVolume& mask, int min_voxels) {
  const auto n = mask.voxelCount();
  std::vector<char> seen(n, 0);
  int count = 0;
  std::deque<std::array<int, 3>> queue;
  for (int k = 0; k < mask.size[2]; ++k) {
    for (int j = 0; j < mask.size[1]; ++j) {
      for (int i = 0; i < mask.size[0]; ++i) {
        const auto start = mask.linearIndex(i, j, k);
        if (seen[start] || mask.data[start] == std::byte{0}) continue;
        seen[start] = 1;
        queue.push_back({i, j, k});
        int voxels = 0;
        while (!queue.empty()) {
          const auto [x, y, z] = queue.front();
          queue.pop_front();
          ++voxels;
          for (int dz = -1; dz <= 1; ++dz) {
            for (int dy = -1; dy <= 1; ++dy) {
              for (int dx = -1; dx <= 1; ++dx) {
                if (!mask.contains(x + dx, y + dy, z + dz)) continue;
                const auto q = mask.linearIndex(x + dx, y + dy, z + dz);
                if (seen[q] || mask.data[q] == std::byte{0}) continue;
                seen[q] = 1;
                queue.push_back({x + dx, y + dy, z + dz});
              }
            }
          }
        }
        if (voxels >= min_voxels) ++count;
      }
    }
  }
  return count;
}

}  // namespace

PreparedCt prepareCt(const registration::PhantomOptions& options, const StepContext& context, double from,
                     double to) {
  PreparedCt ct;
  const auto at = [&](double f) { return from + (to - from) * f; };
  context.report(at(0.0), "generating the cervical phantom CT");
  ct.phantom = registration::generateCervicalPhantom(options);
  checkCancel(context);
  context.report(at(0.4), "meshing the vertebrae");
  registration::LabelMeshOptions mesh_options;
  mesh_options.scheme = registration::LabelScheme::Verse;
  mesh_options.target_triangles = 4000;
  ct.bone_meshes = registration::meshLabelMap(ct.phantom.bone_labels, mesh_options);
  for (const auto& m : ct.bone_meshes.meshes) {
    const auto offset = static_cast<std::int32_t>(ct.bone.vertices.rows());
    ct.bone.vertices.conservativeResize(ct.bone.vertices.rows() + m.mesh.vertices.rows(), 3);
    ct.bone.vertices.bottomRows(m.mesh.vertices.rows()) = m.mesh.vertices;
    ct.bone.faces.conservativeResize(ct.bone.faces.rows() + m.mesh.faces.rows(), 3);
    ct.bone.faces.bottomRows(m.mesh.faces.rows()) = m.mesh.faces.array() + offset;
  }
  ct.bone.frame = "CT";
  checkCancel(context);

  context.report(at(0.7), "finding the fiducial screws in the CT (metal above 2000 HU)");
  const auto& image = ct.phantom.ct;
  const auto metal = sampledMask(image, {0, 0, 0}, image.size, 1, [](double v) { return v > kMetalHu; });
  ct.metal_components = countComponents(metal, 4);
  if (ct.metal_components < 3) {
    throw ComputationError("the CT holds " + std::to_string(ct.metal_components) +
                           " metal screw(s) (voxels above 2000 HU): a landmark registration needs at least 3 "
                           "fiducial screws");
  }
  registration::LabelMeshOptions screw_options;
  screw_options.smoothing_iterations = 0;
  const auto screws = registration::meshLabelMap(metal, screw_options);
  ct.fiducials =
      registration::findFiducialsFromMeshes(screws.meshes.at(0).mesh, ct.bone, ct.metal_components).fiducials;
  return ct;
}

Json screwPathsJson(const registration::CervicalPhantom& phantom) {
  Json paths = Json::array();
  for (const auto& path : phantom.screw_paths) {
    paths.push_back({{"name", path.name},
                     {"entry_ct", {path.entry.x(), path.entry.y(), path.entry.z()}},
                     {"target_ct", {path.target.x(), path.target.y(), path.target.z()}}});
  }
  return paths;
}

}  // namespace mrsns::workflow::detail
