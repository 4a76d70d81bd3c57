// Bone segmentation: input checks and ImageVolume <-> buffer conversion; the
// ITK filters run in ct_itk_filters.cpp.
#include "mrsns/registration/ct_bone_segmentation.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <sstream>

#include "ct_itk_filters.h"
#include "mrsns/core/error.h"
#include "mrsns/core/log.h"

namespace mrsns::registration {
namespace {

void checkImage(const ImageVolume& image, const std::string& what) {
  if (image.empty()) throw InvalidArgumentError(what + " is empty (no voxels): load a volume first");
  if (image.data.size() != image.byteCount()) {
    throw InvalidArgumentError(what + " holds " + std::to_string(image.data.size()) +
                               " bytes but its size and type need " + std::to_string(image.byteCount()));
  }
  if (!(image.spacing.array() > 0.0).all() || !image.spacing.allFinite()) {
    throw InvalidArgumentError(what + " has a non-positive or non-finite spacing");
  }
}

std::string hu(double v) {
  std::ostringstream s;
  s << v;
  return s.str();
}

}  // namespace

BoneSegmentationResult segmentBone(const ImageVolume& ct, const BoneSegmentationOptions& options) {
  checkImage(ct, "CT image '" + ct.name + "'");
  if (!(options.lower_hu < options.upper_hu)) {
    throw InvalidArgumentError("bone threshold: lower_hu (" + hu(options.lower_hu) + ") must be below upper_hu (" +
                               hu(options.upper_hu) + ")");
  }
  const std::size_t n = ct.voxelCount();
  std::vector<float> values(n);
  std::size_t above = 0;
  double max_value = -std::numeric_limits<double>::infinity();
  for (std::size_t i = 0; i < n; ++i) {
    const double v = ct.valueAtIndex(i);
    values[i] = static_cast<float>(v);
    max_value = std::max(max_value, v);
    if (v >= options.lower_hu && v <= options.upper_hu) ++above;
  }
  if (above == 0) {
    throw ComputationError("no voxel above " + hu(options.lower_hu) + " HU: is this a CT? (image '" + ct.name +
                           "', highest value " + hu(max_value) +
                           "; lower the threshold with lower_hu/--threshold if "
                           "it is a CT in other units)");
  }

  detail::VoxelGrid grid;
  for (int a = 0; a < 3; ++a) {
    grid.size[a] = static_cast<std::size_t>(ct.size[a]);
    grid.spacing[a] = ct.spacing[a];
  }
  detail::BoneFilterParams params;
  params.lower = options.lower_hu;
  params.upper = options.upper_hu;
  for (const auto& seed : options.seeds_lps) {
    const Eigen::Vector3d ijk = ct.physicalToIndex(seed);
    const int i = static_cast<int>(std::lround(ijk.x()));
    const int j = static_cast<int>(std::lround(ijk.y()));
    const int k = static_cast<int>(std::lround(ijk.z()));
    if (!ct.contains(i, j, k)) {
      throw InvalidArgumentError("bone seed (" + hu(seed.x()) + ", " + hu(seed.y()) + ", " + hu(seed.z()) +
                                 ") LPS mm lies outside the CT: give seeds inside the image");
    }
    params.seeds.push_back({static_cast<std::size_t>(i), static_cast<std::size_t>(j), static_cast<std::size_t>(k)});
  }
  params.opening_radius_mm = options.opening_radius_mm;
  params.closing_radius_mm = options.closing_radius_mm;
  params.fill_holes = options.fill_holes;
  const double voxel_ml = ct.voxelVolume() / 1000.0;
  params.min_component_voxels = static_cast<std::size_t>(std::ceil(std::max(0.0, options.min_component_ml) / voxel_ml));
  params.keep_largest = options.keep_largest;

  detail::BoneFilterOutput filtered = detail::filterBone(values, grid, params);
  values = {};

  BoneSegmentationResult result;
  result.voxels_above_threshold = filtered.mask_voxels_before_cleanup;
  result.components_found = filtered.components_found;
  if (filtered.component_voxels.empty()) {
    throw ComputationError("bone segmentation of '" + ct.name + "': " + std::to_string(above) + " voxels are above " +
                           hu(options.lower_hu) + " HU but no connected component reaches the minimum size (" +
                           hu(options.min_component_ml) + " ml): lower min_component_ml or check the seeds");
  }
  for (std::size_t c = 0; c < filtered.component_voxels.size(); ++c) {
    BoneComponent component;
    component.label = static_cast<int>(c + 1);
    component.voxels = filtered.component_voxels[c];
    component.volume_ml = static_cast<double>(component.voxels) * voxel_ml;
    result.bone_voxels += component.voxels;
    result.volume_ml += component.volume_ml;
    result.components.push_back(component);
  }

  ImageVolume& labels = result.labels;
  labels.size = ct.size;
  labels.spacing = ct.spacing;
  labels.origin = ct.origin;
  labels.direction = ct.direction;
  labels.frame = ct.frame;
  labels.name = ct.name.empty() ? "bone" : ct.name + "_bone";
  labels.pixel_type = PixelType::UInt16;
  labels.data.resize(n * sizeof(std::uint16_t));
  std::memcpy(labels.data.data(), filtered.labels.data(), labels.data.size());
  logger()->debug("bone segmentation of '{}': {} voxels above {} HU, {} components kept ({:.1f} ml)", ct.name, above,
                  options.lower_hu, result.components.size(), result.volume_ml);
  return result;
}

ImageVolume labelMask(const ImageVolume& label_map, const std::vector<int>& labels) {
  checkImage(label_map, "label map '" + label_map.name + "'");
  ImageVolume mask;
  mask.size = label_map.size;
  mask.spacing = label_map.spacing;
  mask.origin = label_map.origin;
  mask.direction = label_map.direction;
  mask.frame = label_map.frame;
  mask.name = label_map.name + "_mask";
  mask.pixel_type = PixelType::UInt8;
  const std::size_t n = label_map.voxelCount();
  mask.data.assign(n, std::byte{0});
  for (std::size_t i = 0; i < n; ++i) {
    const double v = label_map.valueAtIndex(i);
    bool inside = v != 0.0;
    if (inside && !labels.empty()) {
      inside = std::find(labels.begin(), labels.end(), static_cast<int>(std::lround(v))) != labels.end();
    }
    if (inside) mask.data[i] = std::byte{1};
  }
  return mask;
}

}  // namespace mrsns::registration
