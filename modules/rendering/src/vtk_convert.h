#pragma once
// Copies between core value types and VTK data objects (private to rendering).
#include <vtkSmartPointer.h>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "mrsns/core/image.h"
#include "mrsns/core/mesh.h"

class vtkImageData;
class vtkMatrix4x4;
class vtkPolyData;

namespace mrsns::rendering::detail {

using PointsN3 = Eigen::Matrix<double, Eigen::Dynamic, 3, Eigen::RowMajor>;

/// Points, triangles and (given or computed) vertex normals.
vtkSmartPointer<vtkPolyData> toPolyData(const TriangleMesh& mesh);
/// Overwrites the points (same count) and marks them modified.
void setPoints(vtkPolyData* poly, const PointsN3& vertices);
/// The points of a poly data as rows.
PointsN3 pointsOf(vtkPolyData* poly);

/// One-component uint8 image of a 2D frame: uint8 as is, other types mapped
/// from their own min..max range. Reuses `into` when it has the same size.
vtkSmartPointer<vtkImageData> greyFrame(const ImageVolume& frame, vtkImageData* into = nullptr);

/// The volume's voxels in a vtkImageData with origin 0 and the volume's
/// spacing; place it with indexToLpsMatrix().
vtkSmartPointer<vtkImageData> toImageData(const ImageVolume& volume);
/// [direction | origin]: maps the vtkImageData of toImageData() to LPS.
vtkSmartPointer<vtkMatrix4x4> indexToLpsMatrix(const ImageVolume& volume);

vtkSmartPointer<vtkMatrix4x4> toVtk(const Eigen::Matrix4d& m);
void copyInto(const Eigen::Matrix4d& m, vtkMatrix4x4* into);

/// Throws InvalidArgumentError when rgb is not finite or outside [0, 1].
void checkColor(const Eigen::Vector3d& rgb, const std::string& what);
/// Throws InvalidArgumentError when data size does not match size * pixel type.
void checkImage(const ImageVolume& image, const std::string& what);

}  // namespace mrsns::rendering::detail
