#pragma once
// Label maps to surface meshes: one closed triangle mesh per label, in the LPS
// millimetres of the label map (its direction, origin and spacing applied),
// named and coloured after the label.
#include <Eigen/Core>
#include <cstddef>
#include <map>
#include <string>
#include <vector>

#include "mrsns/core/image.h"
#include "mrsns/core/mesh.h"
#include "mrsns/registration/label_names.h"

namespace mrsns::registration {

struct LabelMeshOptions {
  /// Labels to mesh; empty = every non-zero label present.
  std::vector<int> labels;
  /// Windowed-sinc smoothing iterations (0 = the raw voxel-boundary surface).
  int smoothing_iterations = 15;
  /// Pass band of the windowed-sinc filter (0..2, smaller smooths more).
  double smoothing_pass_band = 0.1;
  /// Quadric decimation to at most this many triangles per label (0 = none).
  std::size_t target_triangles = 0;
  LabelScheme scheme = LabelScheme::Auto;
  /// Names that override the scheme's (label -> name).
  std::map<int, std::string> names;
  /// Frame name copied into the meshes (defaults to the image's frame).
  std::string frame;
};

struct LabelMesh {
  int label = 0;
  std::string name;
  Eigen::Vector3d color = Eigen::Vector3d(0.8, 0.8, 0.8);
  TriangleMesh mesh;  ///< LPS mm, outward counter-clockwise faces, vertex normals and colours
  std::size_t voxels = 0;
  double voxel_volume_ml = 0.0;  ///< voxels x voxel volume
  double mesh_volume_ml = 0.0;   ///< enclosed volume of the mesh
  double surface_area_mm2 = 0.0;
  /// Expected |mesh - voxel| volume from discretisation: surface area x half
  /// the largest voxel edge (ml). Smoothing moves the surface by less than that.
  double volume_tolerance_ml = 0.0;
  bool closed = false;  ///< every edge shared by exactly two faces
  std::size_t triangles_before_decimation = 0;
};

struct LabelMeshingResult {
  std::vector<LabelMesh> meshes;              ///< ascending label
  LabelScheme scheme = LabelScheme::Generic;  ///< the one used (Auto resolved)
};

/// Meshes each requested label with discrete flying edges on the voxel grid
/// (a one-voxel empty border is added so surfaces at the image edge close),
/// windowed-sinc smoothing in millimetres, optional quadric decimation, then
/// the ijk->LPS matrix of the image. Throws InvalidArgumentError for an empty
/// or non-integer image or a requested label that has no voxel.
[[nodiscard]] LabelMeshingResult meshLabelMap(const ImageVolume& label_map, const LabelMeshOptions& options = {});

/// A copy of `mesh` with at most `target_triangles` triangles, for the
/// headset and interactive views: quadric decimation with volume
/// preservation, or DecimatePro with its topology kept when quadric
/// decimation would open a closed surface. A mesh already that small comes
/// back unchanged. Normals are recomputed, the first vertex's colour kept.
/// Throws InvalidArgumentError for an invalid mesh or a target below 4.
[[nodiscard]] TriangleMesh decimateMesh(const TriangleMesh& mesh, std::size_t target_triangles);

/// Distinct non-zero integer labels of a label map with their voxel counts
/// (ascending). Throws InvalidArgumentError if a voxel is not an integer.
[[nodiscard]] std::map<int, std::size_t> labelVoxelCounts(const ImageVolume& label_map);

}  // namespace mrsns::registration
