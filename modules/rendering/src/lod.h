#pragma once
// Decimated copies of meshes for interactive frame rates, and how they follow
// the full mesh when it deforms (private to rendering).
#include <vtkSmartPointer.h>

#include <vector>

#include "vtk_convert.h"

class vtkPolyData;

namespace mrsns::rendering::detail {

struct DecimatedCopy {
  vtkSmartPointer<vtkPolyData> poly;
  /// For each decimated vertex, the nearest vertex of the full mesh: a
  /// deformation moves it by that vertex's displacement, and it takes that
  /// vertex's scalar, so no decimation runs per frame.
  std::vector<Eigen::Index> source;
  PointsN3 rest;  ///< decimated vertices when the copy was made
};

/// Quadric decimation keeping about `keep_fraction` of the triangles.
DecimatedCopy decimate(vtkPolyData* full, double keep_fraction);

/// Moves the copy for full-mesh vertices `now` that were `full_rest` when it was made.
void followDeformation(DecimatedCopy& copy, const PointsN3& full_rest, const PointsN3& now);

}  // namespace mrsns::rendering::detail
