#pragma once
// The one place the registration module calls ITK (ct_itk_filters.cpp). ITK
// 5.2 bundles its own Eigen 3.3 under the same include guards and namespace
// as the system Eigen the rest of MR-SNS uses (see modules/io/src/itk_bridge.h),
// so this interface holds standard-library types only and
// ct_bone_segmentation.cpp turns them into ImageVolume.
#include <array>
#include <cstddef>
#include <cstdint>
#include <vector>

namespace mrsns::registration::detail {

/// Voxel grid of a buffer stored i fastest (as ImageVolume), spacing in mm.
struct VoxelGrid {
  std::array<std::size_t, 3> size{0, 0, 0};
  std::array<double, 3> spacing{1, 1, 1};
};

struct BoneFilterParams {
  double lower = 250.0;
  double upper = 1e9;
  std::vector<std::array<std::size_t, 3>> seeds;  ///< region growing from these voxels when not empty
  double opening_radius_mm = 0.0;
  double closing_radius_mm = 0.0;
  bool fill_holes = true;
  std::size_t min_component_voxels = 1;
  std::size_t keep_largest = 0;  ///< 0: every component of at least min_component_voxels
};

struct BoneFilterOutput {
  std::vector<std::uint16_t> labels;          ///< 0 background, 1..K kept components, largest first
  std::vector<std::size_t> component_voxels;  ///< voxels of components 1..K
  std::size_t components_found = 0;           ///< before size selection
  std::size_t mask_voxels_before_cleanup = 0;
};

/// Threshold (or connected-threshold region growing), opening, closing, hole
/// filling, then connected components (face connectivity) sorted by size.
BoneFilterOutput filterBone(const std::vector<float>& values, const VoxelGrid& grid, const BoneFilterParams& params);

}  // namespace mrsns::registration::detail
