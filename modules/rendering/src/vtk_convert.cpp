#include "vtk_convert.h"

#include <vtkCellArray.h>
#include <vtkFloatArray.h>
#include <vtkIdTypeArray.h>
#include <vtkImageData.h>
#include <vtkMatrix4x4.h>
#include <vtkPointData.h>
#include <vtkPoints.h>
#include <vtkPolyData.h>
#include <vtkType.h>
#include <vtkUnsignedCharArray.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>

#include "mrsns/core/error.h"
#include "mrsns/core/mesh_ops.h"

namespace mrsns::rendering::detail {

vtkSmartPointer<vtkPolyData> toPolyData(const TriangleMesh& mesh) {
  auto points = vtkSmartPointer<vtkPoints>::New();
  points->SetDataTypeToFloat();
  points->SetNumberOfPoints(mesh.vertexCount());
  for (Eigen::Index i = 0; i < mesh.vertexCount(); ++i) {
    points->SetPoint(i, mesh.vertices(i, 0), mesh.vertices(i, 1), mesh.vertices(i, 2));
  }
  // One flat connectivity array: building cells one by one costs ~3x more
  // for the 100k-triangle meshes of a CT.
  auto offsets = vtkSmartPointer<vtkIdTypeArray>::New();
  offsets->SetNumberOfValues(mesh.faceCount() + 1);
  auto connectivity = vtkSmartPointer<vtkIdTypeArray>::New();
  connectivity->SetNumberOfValues(3 * mesh.faceCount());
  for (Eigen::Index f = 0; f < mesh.faceCount(); ++f) {
    offsets->SetValue(f, 3 * f);
    for (int c = 0; c < 3; ++c) connectivity->SetValue(3 * f + c, mesh.faces(f, c));
  }
  offsets->SetValue(mesh.faceCount(), 3 * mesh.faceCount());
  auto cells = vtkSmartPointer<vtkCellArray>::New();
  cells->SetData(offsets, connectivity);
  auto poly = vtkSmartPointer<vtkPolyData>::New();
  poly->SetPoints(points);
  poly->SetPolys(cells);

  const PointsN3 normals = mesh.normals.rows() == mesh.vertexCount() ? mesh.normals : vertexNormals(mesh);
  auto n = vtkSmartPointer<vtkFloatArray>::New();
  n->SetName("Normals");
  n->SetNumberOfComponents(3);
  n->SetNumberOfTuples(mesh.vertexCount());
  for (Eigen::Index i = 0; i < mesh.vertexCount(); ++i) {
    n->SetTuple3(i, normals(i, 0), normals(i, 1), normals(i, 2));
  }
  poly->GetPointData()->SetNormals(n);
  return poly;
}

void setPoints(vtkPolyData* poly, const PointsN3& vertices) {
  vtkPoints* points = poly->GetPoints();
  for (Eigen::Index i = 0; i < vertices.rows(); ++i) {
    points->SetPoint(i, vertices(i, 0), vertices(i, 1), vertices(i, 2));
  }
  points->Modified();
  poly->Modified();
}

PointsN3 pointsOf(vtkPolyData* poly) {
  PointsN3 out(poly->GetNumberOfPoints(), 3);
  for (vtkIdType i = 0; i < poly->GetNumberOfPoints(); ++i) {
    double p[3];
    poly->GetPoint(i, p);
    out.row(i) = Eigen::Vector3d(p[0], p[1], p[2]);
  }
  return out;
}

void checkImage(const ImageVolume& image, const std::string& what) {
  if (image.empty()) throw InvalidArgumentError(what + " is empty: give an image with at least one pixel");
  if (image.data.size() != image.byteCount()) {
    throw InvalidArgumentError(what + " holds " + std::to_string(image.data.size()) +
                               " bytes but its size and pixel type need " + std::to_string(image.byteCount()));
  }
  if (!image.spacing.allFinite() || (image.spacing.array() <= 0.0).any() || !image.origin.allFinite() ||
      !image.direction.allFinite()) {
    throw InvalidArgumentError(what + " has a non-positive or non-finite spacing, origin or direction");
  }
}

vtkSmartPointer<vtkImageData> greyFrame(const ImageVolume& frame, vtkImageData* into) {
  vtkSmartPointer<vtkImageData> image = into;
  int dims[3] = {0, 0, 0};
  if (image) image->GetDimensions(dims);
  if (!image || dims[0] != frame.size[0] || dims[1] != frame.size[1] || image->GetScalarType() != VTK_UNSIGNED_CHAR) {
    image = vtkSmartPointer<vtkImageData>::New();
    image->SetDimensions(frame.size[0], frame.size[1], 1);
    image->AllocateScalars(VTK_UNSIGNED_CHAR, 1);
  }
  auto* out = static_cast<unsigned char*>(image->GetScalarPointer());
  const std::size_t n = static_cast<std::size_t>(frame.size[0]) * static_cast<std::size_t>(frame.size[1]);
  if (frame.pixel_type == PixelType::UInt8) {
    std::memcpy(out, frame.data.data(), n);
  } else {
    double lo = std::numeric_limits<double>::infinity();
    double hi = -lo;
    for (std::size_t i = 0; i < n; ++i) {
      const double v = frame.valueAtIndex(i);
      if (std::isfinite(v)) {
        lo = std::min(lo, v);
        hi = std::max(hi, v);
      }
    }
    const double scale = hi > lo ? 255.0 / (hi - lo) : 0.0;
    for (std::size_t i = 0; i < n; ++i) {
      const double v = frame.valueAtIndex(i);
      out[i] = std::isfinite(v) ? static_cast<unsigned char>(std::clamp((v - lo) * scale, 0.0, 255.0) + 0.5) : 0;
    }
  }
  image->GetPointData()->GetScalars()->Modified();
  image->Modified();
  return image;
}

vtkSmartPointer<vtkImageData> toImageData(const ImageVolume& volume) {
  int type = VTK_UNSIGNED_CHAR;
  switch (volume.pixel_type) {
    case PixelType::UInt8: type = VTK_UNSIGNED_CHAR; break;
    case PixelType::Int8: type = VTK_SIGNED_CHAR; break;
    case PixelType::UInt16: type = VTK_UNSIGNED_SHORT; break;
    case PixelType::Int16: type = VTK_SHORT; break;
    case PixelType::UInt32: type = VTK_UNSIGNED_INT; break;
    case PixelType::Int32: type = VTK_INT; break;
    case PixelType::Float32: type = VTK_FLOAT; break;
    case PixelType::Float64: type = VTK_DOUBLE; break;
  }
  auto image = vtkSmartPointer<vtkImageData>::New();
  image->SetDimensions(volume.size[0], volume.size[1], volume.size[2]);
  image->SetSpacing(volume.spacing.x(), volume.spacing.y(), volume.spacing.z());
  image->SetOrigin(0.0, 0.0, 0.0);
  image->AllocateScalars(type, 1);
  std::memcpy(image->GetScalarPointer(), volume.data.data(), volume.byteCount());
  return image;
}

vtkSmartPointer<vtkMatrix4x4> indexToLpsMatrix(const ImageVolume& volume) {
  Eigen::Matrix4d m = Eigen::Matrix4d::Identity();
  m.topLeftCorner<3, 3>() = volume.direction;
  m.topRightCorner<3, 1>() = volume.origin;
  return toVtk(m);
}

vtkSmartPointer<vtkMatrix4x4> toVtk(const Eigen::Matrix4d& m) {
  auto out = vtkSmartPointer<vtkMatrix4x4>::New();
  copyInto(m, out);
  return out;
}

void copyInto(const Eigen::Matrix4d& m, vtkMatrix4x4* into) {
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 4; ++c) into->SetElement(r, c, m(r, c));
  into->Modified();
}

void checkColor(const Eigen::Vector3d& rgb, const std::string& what) {
  if (!rgb.allFinite() || (rgb.array() < 0.0).any() || (rgb.array() > 1.0).any()) {
    throw InvalidArgumentError(what + ": colour components must lie in [0, 1] (RGB fractions, not 0-255)");
  }
}

}  // namespace mrsns::rendering::detail
