// All ITK calls of the registration module, in one translation unit (each ITK
// TU costs ~9 s to compile) and without Eigen/core geometry headers (see
// ct_itk_filters.h for why).
#include "ct_itk_filters.h"

#include <itkBinaryBallStructuringElement.h>
#include <itkBinaryFillholeImageFilter.h>
#include <itkBinaryMorphologicalClosingImageFilter.h>
#include <itkBinaryMorphologicalOpeningImageFilter.h>
#include <itkBinaryThresholdImageFilter.h>
#include <itkConnectedComponentImageFilter.h>
#include <itkConnectedThresholdImageFilter.h>
#include <itkImage.h>
#include <itkImageRegionConstIterator.h>
#include <itkRelabelComponentImageFilter.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <string>

#include "mrsns/core/error.h"

namespace mrsns::registration::detail {
namespace {

using FloatImage = itk::Image<float, 3>;
using MaskImage = itk::Image<std::uint8_t, 3>;
using LabelImage = itk::Image<std::uint32_t, 3>;
using Ball = itk::BinaryBallStructuringElement<std::uint8_t, 3>;

template <typename Image>
typename Image::Pointer makeImage(const VoxelGrid& grid) {
  auto image = Image::New();
  typename Image::RegionType region;
  typename Image::SpacingType spacing;
  for (unsigned a = 0; a < 3; ++a) {
    region.SetIndex(a, 0);
    region.SetSize(a, grid.size[a]);
    spacing[a] = grid.spacing[a];
  }
  image->SetRegions(region);
  image->SetSpacing(spacing);
  image->Allocate();
  return image;
}

std::size_t voxelCount(const VoxelGrid& grid) {
  return grid.size[0] * grid.size[1] * grid.size[2];
}

/// Ball radius in voxels per axis: a radius in mm that is positive always
/// acts on at least one voxel, so a 1 mm closing is not lost on 3 mm CTs.
Ball makeBall(double radius_mm, const VoxelGrid& grid) {
  Ball::SizeType radius;
  for (unsigned a = 0; a < 3; ++a) {
    radius[a] = std::max<long>(1, std::lround(radius_mm / grid.spacing[a]));
  }
  Ball ball;
  ball.SetRadius(radius);
  ball.CreateStructuringElement();
  return ball;
}

std::size_t countForeground(const MaskImage* mask) {
  std::size_t n = 0;
  itk::ImageRegionConstIterator<MaskImage> it(mask, mask->GetLargestPossibleRegion());
  for (it.GoToBegin(); !it.IsAtEnd(); ++it) n += it.Get() != 0 ? 1 : 0;
  return n;
}

BoneFilterOutput filterBoneUnguarded(const std::vector<float>& values, const VoxelGrid& grid,
                                     const BoneFilterParams& params) {
  auto input = makeImage<FloatImage>(grid);
  std::memcpy(input->GetBufferPointer(), values.data(), values.size() * sizeof(float));

  MaskImage::Pointer mask;
  if (params.seeds.empty()) {
    auto threshold = itk::BinaryThresholdImageFilter<FloatImage, MaskImage>::New();
    threshold->SetInput(input);
    threshold->SetLowerThreshold(static_cast<float>(params.lower));
    threshold->SetUpperThreshold(static_cast<float>(std::min(params.upper, 3.0e38)));
    threshold->SetInsideValue(1);
    threshold->SetOutsideValue(0);
    threshold->Update();
    mask = threshold->GetOutput();
  } else {
    auto grow = itk::ConnectedThresholdImageFilter<FloatImage, MaskImage>::New();
    grow->SetInput(input);
    grow->SetLower(static_cast<float>(params.lower));
    grow->SetUpper(static_cast<float>(std::min(params.upper, 3.0e38)));
    grow->SetReplaceValue(1);
    for (const auto& s : params.seeds) {
      FloatImage::IndexType index;
      for (unsigned a = 0; a < 3; ++a) index[a] = static_cast<itk::IndexValueType>(s[a]);
      grow->AddSeed(index);
    }
    grow->Update();
    mask = grow->GetOutput();
  }
  mask->DisconnectPipeline();

  BoneFilterOutput out;
  out.mask_voxels_before_cleanup = countForeground(mask);

  if (params.opening_radius_mm > 0.0) {
    auto opening = itk::BinaryMorphologicalOpeningImageFilter<MaskImage, MaskImage, Ball>::New();
    opening->SetInput(mask);
    opening->SetKernel(makeBall(params.opening_radius_mm, grid));
    opening->SetForegroundValue(1);
    opening->SetBackgroundValue(0);
    opening->Update();
    mask = opening->GetOutput();
    mask->DisconnectPipeline();
  }
  if (params.closing_radius_mm > 0.0) {
    auto closing = itk::BinaryMorphologicalClosingImageFilter<MaskImage, MaskImage, Ball>::New();
    closing->SetInput(mask);
    closing->SetKernel(makeBall(params.closing_radius_mm, grid));
    closing->SetForegroundValue(1);
    closing->SetSafeBorder(true);
    closing->Update();
    mask = closing->GetOutput();
    mask->DisconnectPipeline();
  }
  if (params.fill_holes) {
    auto fill = itk::BinaryFillholeImageFilter<MaskImage>::New();
    fill->SetInput(mask);
    fill->SetForegroundValue(1);
    fill->SetFullyConnected(false);
    fill->Update();
    mask = fill->GetOutput();
    mask->DisconnectPipeline();
  }

  auto components = itk::ConnectedComponentImageFilter<MaskImage, LabelImage>::New();
  components->SetInput(mask);
  components->SetFullyConnected(false);
  components->SetBackgroundValue(0);
  auto relabel = itk::RelabelComponentImageFilter<LabelImage, LabelImage>::New();
  relabel->SetInput(components->GetOutput());
  relabel->SetSortByObjectSize(true);
  relabel->SetMinimumObjectSize(std::max<std::size_t>(params.min_component_voxels, 1));
  relabel->Update();
  out.components_found = components->GetObjectCount();

  std::size_t kept = relabel->GetNumberOfObjects();
  if (params.keep_largest > 0) kept = std::min(kept, params.keep_largest);
  if (kept > 65535) kept = 65535;
  const auto& sizes = relabel->GetSizeOfObjectsInPixels();
  out.component_voxels.assign(sizes.begin(), sizes.begin() + static_cast<std::ptrdiff_t>(kept));

  const LabelImage* labels = relabel->GetOutput();
  const std::uint32_t* buffer = labels->GetBufferPointer();
  const std::size_t n = voxelCount(grid);
  out.labels.resize(n);
  for (std::size_t i = 0; i < n; ++i) {
    out.labels[i] = buffer[i] <= kept ? static_cast<std::uint16_t>(buffer[i]) : std::uint16_t{0};
  }
  return out;
}

}  // namespace

BoneFilterOutput filterBone(const std::vector<float>& values, const VoxelGrid& grid, const BoneFilterParams& params) {
  if (values.size() != voxelCount(grid)) {
    throw InvalidArgumentError("filterBone: " + std::to_string(values.size()) + " values for a grid of " +
                               std::to_string(voxelCount(grid)) + " voxels");
  }
  try {
    return filterBoneUnguarded(values, grid, params);
  } catch (const itk::ExceptionObject& e) {
    throw ComputationError(std::string("bone segmentation failed inside ITK: ") + e.GetDescription());
  }
}

}  // namespace mrsns::registration::detail
