#pragma once
// Bone from CT: a HU threshold (or connected-threshold region growing from
// seeds), morphological clean-up and connected components, giving a label map
// on the CT's own grid (LPS geometry copied from the input).
#include <Eigen/Core>
#include <cstddef>
#include <vector>

#include "mrsns/core/image.h"

namespace mrsns::registration {

struct BoneSegmentationOptions {
  /// Lowest HU kept as bone. 250 keeps cortical bone and most cancellous bone
  /// of adults; cancellous bone of osteoporotic patients can be 100-200 HU,
  /// where hole filling recovers it inside a closed cortex.
  double lower_hu = 250.0;
  /// Highest HU kept (metal is ~3000 HU; lower this to drop implants).
  double upper_hu = 1e9;
  /// Region growing from these LPS points (mm) instead of a global threshold
  /// when not empty: only bone connected to a seed is kept.
  std::vector<Eigen::Vector3d> seeds_lps;
  /// Binary opening radius (mm): removes specks and thin bridges; 0 = off.
  double opening_radius_mm = 0.0;
  /// Binary closing radius (mm): closes gaps in thin cortex; 0 = off. A
  /// positive radius acts on at least one voxel whatever the spacing.
  double closing_radius_mm = 1.0;
  /// Fills cavities fully enclosed by bone (cancellous bone below the threshold).
  bool fill_holes = true;
  /// Components smaller than this are dropped (noise, calcifications).
  double min_component_ml = 0.1;
  /// Keep only the N largest components (0 = all above min_component_ml).
  std::size_t keep_largest = 0;
};

struct BoneComponent {
  int label = 0;  ///< in the label map
  std::size_t voxels = 0;
  double volume_ml = 0.0;
};

struct BoneSegmentationResult {
  /// uint16 label map on the CT grid: 0 background, 1..K bone components by decreasing size.
  ImageVolume labels;
  std::size_t voxels_above_threshold = 0;  ///< before clean-up (threshold or region growing)
  std::size_t bone_voxels = 0;             ///< in the kept components
  double volume_ml = 0.0;                  ///< of the kept components
  std::size_t components_found = 0;        ///< after clean-up, before size selection
  std::vector<BoneComponent> components;   ///< kept, largest first
};

/// Segments bone in a CT in HU. Throws InvalidArgumentError for an empty or
/// inconsistent image or a seed outside it, ComputationError when no voxel
/// reaches the threshold ("is this a CT?") or nothing survives the clean-up.
[[nodiscard]] BoneSegmentationResult segmentBone(const ImageVolume& ct, const BoneSegmentationOptions& options = {});

/// A binary (0/1, uint8) mask of the voxels whose label is in `labels` (any
/// non-zero label when `labels` is empty), same grid as `label_map`.
[[nodiscard]] ImageVolume labelMask(const ImageVolume& label_map, const std::vector<int>& labels = {});

}  // namespace mrsns::registration
