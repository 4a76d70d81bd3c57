#include "lod.h"

#include <vtkPolyData.h>
#include <vtkPolyDataNormals.h>
#include <vtkQuadricDecimation.h>

#include <algorithm>

#include "mrsns/core/point_locator.h"

namespace mrsns::rendering::detail {

DecimatedCopy decimate(vtkPolyData* full, double keep_fraction) {
  auto decimation = vtkSmartPointer<vtkQuadricDecimation>::New();
  decimation->SetInputData(full);
  decimation->SetTargetReduction(std::clamp(1.0 - keep_fraction, 0.0, 0.99));
  decimation->VolumePreservationOn();
  // Normals are recomputed below from the decimated faces; carrying the full
  // mesh's attributes through the quadric error would only slow it down.
  decimation->AttributeErrorMetricOff();
  auto normals = vtkSmartPointer<vtkPolyDataNormals>::New();
  normals->SetInputConnection(decimation->GetOutputPort());
  normals->SplittingOff();
  normals->ConsistencyOff();
  normals->Update();
  DecimatedCopy copy;
  copy.poly = vtkSmartPointer<vtkPolyData>::New();
  copy.poly->DeepCopy(normals->GetOutput());
  copy.rest = pointsOf(copy.poly);
  const PointLocator locator(pointsOf(full));
  copy.source.resize(static_cast<std::size_t>(copy.rest.rows()));
  for (Eigen::Index i = 0; i < copy.rest.rows(); ++i) {
    copy.source[static_cast<std::size_t>(i)] = locator.nearest(copy.rest.row(i).transpose()).index;
  }
  return copy;
}

void followDeformation(DecimatedCopy& copy, const PointsN3& full_rest, const PointsN3& now) {
  PointsN3 moved(copy.rest.rows(), 3);
  for (Eigen::Index i = 0; i < copy.rest.rows(); ++i) {
    const Eigen::Index s = copy.source[static_cast<std::size_t>(i)];
    moved.row(i) = copy.rest.row(i) + (now.row(s) - full_rest.row(s));
  }
  setPoints(copy.poly, moved);
}

}  // namespace mrsns::rendering::detail
