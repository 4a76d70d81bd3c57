// Label maps to meshes with VTK: the registration module's only VTK
// translation unit.
#include "mrsns/registration/label_meshing.h"

#include <vtkCellArray.h>
#include <vtkDecimatePro.h>
#include <vtkDiscreteFlyingEdges3D.h>
#include <vtkIdList.h>
#include <vtkImageData.h>
#include <vtkNew.h>
#include <vtkPointData.h>
#include <vtkPoints.h>
#include <vtkPolyData.h>
#include <vtkQuadricDecimation.h>
#include <vtkSmartPointer.h>
#include <vtkUnsignedCharArray.h>
#include <vtkWindowedSincPolyDataFilter.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <mutex>

#include "mrsns/core/error.h"
#include "mrsns/core/log.h"
#include "mrsns/core/mesh_ops.h"
#include "mrsns/core/parallel.h"

namespace mrsns::registration {
namespace {

struct LabelBox {
  std::size_t voxels = 0;
  std::array<int, 3> lo{0, 0, 0};
  std::array<int, 3> hi{-1, -1, -1};
};

void quietVtk() {
  static std::once_flag once;
  std::call_once(once, [] { vtkObject::GlobalWarningDisplayOff(); });
}

void checkLabelMap(const ImageVolume& image) {
  if (image.empty()) throw InvalidArgumentError("label map '" + image.name + "' is empty (no voxels)");
  if (image.data.size() != image.byteCount()) {
    throw InvalidArgumentError("label map '" + image.name + "' holds " + std::to_string(image.data.size()) +
                               " bytes but its size and type need " + std::to_string(image.byteCount()));
  }
  if (!(image.spacing.array() > 0.0).all() || !image.spacing.allFinite()) {
    throw InvalidArgumentError("label map '" + image.name + "' has a non-positive or non-finite spacing");
  }
}

std::map<int, LabelBox> labelBoxes(const ImageVolume& image) {
  std::map<int, LabelBox> boxes;
  std::size_t index = 0;
  for (int k = 0; k < image.size[2]; ++k) {
    for (int j = 0; j < image.size[1]; ++j) {
      for (int i = 0; i < image.size[0]; ++i, ++index) {
        const double v = image.valueAtIndex(index);
        if (v == 0.0) continue;
        const double r = std::round(v);
        if (r != v || std::abs(r) > 2.0e9) {
          throw InvalidArgumentError("image '" + image.name + "' is not a label map: voxel (" + std::to_string(i) +
                                     ", " + std::to_string(j) + ", " + std::to_string(k) + ") holds " +
                                     std::to_string(v) + "; give an integer label image");
        }
        LabelBox& box = boxes[static_cast<int>(r)];
        if (box.voxels++ == 0) {
          box.lo = {i, j, k};
          box.hi = {i, j, k};
        } else {
          box.lo = {std::min(box.lo[0], i), std::min(box.lo[1], j), std::min(box.lo[2], k)};
          box.hi = {std::max(box.hi[0], i), std::max(box.hi[1], j), std::max(box.hi[2], k)};
        }
      }
    }
  }
  return boxes;
}

/// Binary image of one label over its bounding box plus a one-voxel empty
/// border, in "scaled index" space: spacing applied, no direction, origin at
/// the box corner; the LPS transform comes after smoothing so that smoothing
/// sees millimetres even on anisotropic grids.
vtkSmartPointer<vtkImageData> labelImage(const ImageVolume& image, int label, const LabelBox& box) {
  const std::array<int, 3> dims{box.hi[0] - box.lo[0] + 3, box.hi[1] - box.lo[1] + 3, box.hi[2] - box.lo[2] + 3};
  auto vtk_image = vtkSmartPointer<vtkImageData>::New();
  vtk_image->SetDimensions(dims[0], dims[1], dims[2]);
  vtk_image->SetSpacing(image.spacing.x(), image.spacing.y(), image.spacing.z());
  vtk_image->SetOrigin((box.lo[0] - 1) * image.spacing.x(), (box.lo[1] - 1) * image.spacing.y(),
                       (box.lo[2] - 1) * image.spacing.z());
  vtkNew<vtkUnsignedCharArray> scalars;
  scalars->SetNumberOfTuples(static_cast<vtkIdType>(dims[0]) * dims[1] * dims[2]);
  scalars->FillValue(0);
  unsigned char* out = scalars->GetPointer(0);
  for (int k = box.lo[2]; k <= box.hi[2]; ++k) {
    for (int j = box.lo[1]; j <= box.hi[1]; ++j) {
      for (int i = box.lo[0]; i <= box.hi[0]; ++i) {
        if (image.value(i, j, k) != static_cast<double>(label)) continue;
        const std::size_t o = (static_cast<std::size_t>(k - box.lo[2] + 1) * static_cast<std::size_t>(dims[1]) +
                               static_cast<std::size_t>(j - box.lo[1] + 1)) *
                                  static_cast<std::size_t>(dims[0]) +
                              static_cast<std::size_t>(i - box.lo[0] + 1);
        out[o] = 1;
      }
    }
  }
  vtk_image->GetPointData()->SetScalars(scalars);
  return vtk_image;
}

TriangleMesh toTriangleMesh(vtkPolyData* poly, const ImageVolume& image) {
  TriangleMesh mesh;
  const vtkIdType n_points = poly->GetNumberOfPoints();
  mesh.vertices.resize(n_points, 3);
  for (vtkIdType p = 0; p < n_points; ++p) {
    double xyz[3];
    poly->GetPoint(p, xyz);
    // Scaled index -> LPS: p = origin + direction * (spacing * ijk).
    mesh.vertices.row(p) = (image.origin + image.direction * Eigen::Vector3d(xyz[0], xyz[1], xyz[2])).transpose();
  }
  vtkCellArray* polys = poly->GetPolys();
  std::vector<std::array<std::int32_t, 3>> faces;
  faces.reserve(static_cast<std::size_t>(polys->GetNumberOfCells()));
  vtkNew<vtkIdList> ids;
  for (polys->InitTraversal(); polys->GetNextCell(ids);) {
    // Fan-triangulate anything that is not a triangle (decimation returns triangles).
    for (vtkIdType t = 1; t + 1 < ids->GetNumberOfIds(); ++t) {
      faces.push_back({static_cast<std::int32_t>(ids->GetId(0)), static_cast<std::int32_t>(ids->GetId(t)),
                       static_cast<std::int32_t>(ids->GetId(t + 1))});
    }
  }
  mesh.faces.resize(static_cast<Eigen::Index>(faces.size()), 3);
  for (std::size_t f = 0; f < faces.size(); ++f) {
    mesh.faces.row(static_cast<Eigen::Index>(f)) << faces[f][0], faces[f][1], faces[f][2];
  }
  return mesh;
}


/// Topology only (identity geometry): what the closedness test needs.
TriangleMesh topologyOf(vtkPolyData* poly) {
  ImageVolume identity;
  return toTriangleMesh(poly, identity);
}

vtkSmartPointer<vtkPolyData> decimatePoly(vtkPolyData* poly, std::size_t target_triangles) {
  const auto before = static_cast<std::size_t>(poly->GetNumberOfPolys());
  const double reduction = 1.0 - static_cast<double>(target_triangles) / static_cast<double>(before);
  vtkNew<vtkQuadricDecimation> quadric;
  quadric->SetInputData(poly);
  quadric->SetTargetReduction(reduction);
  quadric->VolumePreservationOn();
  quadric->Update();
  // Quadric decimation reaches the target and keeps the shape best, but can
  // pinch a large, thin surface into non-manifold edges; then fall back to
  // DecimatePro, whose topology preservation keeps the surface closed.
  const bool was_closed = isClosed(topologyOf(poly));
  if (!was_closed || isClosed(topologyOf(quadric->GetOutput()))) {
    vtkSmartPointer<vtkPolyData> out = quadric->GetOutput();
    return out;
  }
  vtkNew<vtkDecimatePro> pro;
  pro->SetInputData(poly);
  pro->SetTargetReduction(reduction);
  pro->PreserveTopologyOn();
  pro->SplittingOff();
  pro->BoundaryVertexDeletionOff();
  pro->Update();
  vtkSmartPointer<vtkPolyData> out = pro->GetOutput();
  return out;
}

vtkSmartPointer<vtkPolyData> toPolyData(const TriangleMesh& mesh) {
  vtkNew<vtkPoints> points;
  points->SetDataTypeToDouble();
  points->SetNumberOfPoints(mesh.vertices.rows());
  for (Eigen::Index v = 0; v < mesh.vertices.rows(); ++v) {
    points->SetPoint(v, mesh.vertices(v, 0), mesh.vertices(v, 1), mesh.vertices(v, 2));
  }
  vtkNew<vtkCellArray> cells;
  cells->AllocateExact(mesh.faces.rows(), mesh.faces.rows() * 3);
  for (Eigen::Index f = 0; f < mesh.faces.rows(); ++f) {
    const vtkIdType ids[3] = {mesh.faces(f, 0), mesh.faces(f, 1), mesh.faces(f, 2)};
    cells->InsertNextCell(3, ids);
  }
  auto poly = vtkSmartPointer<vtkPolyData>::New();
  poly->SetPoints(points);
  poly->SetPolys(cells);
  return poly;
}

}  // namespace

std::map<int, std::size_t> labelVoxelCounts(const ImageVolume& label_map) {
  checkLabelMap(label_map);
  std::map<int, std::size_t> counts;
  for (const auto& [label, box] : labelBoxes(label_map)) counts[label] = box.voxels;
  return counts;
}

namespace {

LabelMesh meshOneLabel(const ImageVolume& label_map, int label, const LabelBox& box, LabelScheme scheme,
                       const LabelMeshOptions& options, double voxel_ml, double half_voxel) {
    auto image = labelImage(label_map, label, box);
    vtkNew<vtkDiscreteFlyingEdges3D> surface;
    surface->SetInputData(image);
    surface->SetValue(0, 1.0);
    surface->ComputeNormalsOff();
    surface->ComputeGradientsOff();
    surface->ComputeScalarsOff();
    surface->Update();
    vtkSmartPointer<vtkPolyData> poly = surface->GetOutput();

    if (options.smoothing_iterations > 0) {
      vtkNew<vtkWindowedSincPolyDataFilter> smooth;
      smooth->SetInputData(poly);
      smooth->SetNumberOfIterations(options.smoothing_iterations);
      smooth->SetPassBand(options.smoothing_pass_band);
      smooth->BoundarySmoothingOff();
      smooth->FeatureEdgeSmoothingOff();
      smooth->NonManifoldSmoothingOn();
      smooth->NormalizeCoordinatesOn();
      smooth->Update();
      poly = smooth->GetOutput();
    }
    const auto triangles_before = static_cast<std::size_t>(poly->GetNumberOfPolys());
    if (options.target_triangles > 0 && triangles_before > options.target_triangles) {
      poly = decimatePoly(poly, options.target_triangles);
    }
    LabelMesh out;
    out.label = label;
    LabelInfo info = labelInfo(label, scheme);
    if (const auto named = options.names.find(label); named != options.names.end()) info.name = named->second;
    out.name = info.name;
    out.color = info.color;
    out.voxels = box.voxels;
    out.voxel_volume_ml = static_cast<double>(out.voxels) * voxel_ml;
    out.triangles_before_decimation = triangles_before;
    out.mesh = toTriangleMesh(poly, label_map);
    out.mesh.name = info.name;
    out.mesh.frame = options.frame.empty() ? label_map.frame : options.frame;
    if (out.mesh.empty()) {
      throw ComputationError("label " + std::to_string(label) + " ('" + info.name + "') gave an empty surface");
    }
    // A direction matrix with determinant -1 mirrors the surface: restore outward faces.
    if (signedVolume(out.mesh) < 0.0) out.mesh.faces.col(1).swap(out.mesh.faces.col(2));
    out.mesh.normals = vertexNormals(out.mesh);
    out.mesh.colors = out.color.transpose().replicate(out.mesh.vertexCount(), 1);
    out.mesh_volume_ml = signedVolume(out.mesh) / 1000.0;
    out.surface_area_mm2 = surfaceArea(out.mesh);
    out.volume_tolerance_ml = out.surface_area_mm2 * half_voxel / 1000.0;
    out.closed = isClosed(out.mesh);
    return out;
}

}  // namespace

TriangleMesh decimateMesh(const TriangleMesh& mesh, std::size_t target_triangles) {
  validateMesh(mesh, "the mesh to decimate");
  if (target_triangles < 4) {
    throw InvalidArgumentError("decimation needs a target of at least 4 triangles (got " +
                               std::to_string(target_triangles) + ")");
  }
  if (static_cast<std::size_t>(mesh.faces.rows()) <= target_triangles) return mesh;
  quietVtk();
  auto poly = decimatePoly(toPolyData(mesh), target_triangles);
  ImageVolume identity;
  TriangleMesh out = toTriangleMesh(poly, identity);
  out.name = mesh.name;
  out.frame = mesh.frame;
  if (out.empty()) throw ComputationError("decimating '" + mesh.name + "' left no triangle");
  out.normals = vertexNormals(out);
  if (mesh.colors.rows() > 0) out.colors = mesh.colors.row(0).replicate(out.vertexCount(), 1);
  return out;
}

LabelMeshingResult meshLabelMap(const ImageVolume& label_map, const LabelMeshOptions& options) {
  checkLabelMap(label_map);
  quietVtk();
  if (options.smoothing_iterations < 0) {
    throw InvalidArgumentError("smoothing iterations must be >= 0 (got " +
                               std::to_string(options.smoothing_iterations) + ")");
  }
  if (!(options.smoothing_pass_band > 0.0 && options.smoothing_pass_band <= 2.0)) {
    throw InvalidArgumentError("smoothing pass band must lie in (0, 2]");
  }
  const auto boxes = labelBoxes(label_map);
  std::vector<int> present;
  for (const auto& entry : boxes) present.push_back(entry.first);
  if (present.empty()) {
    throw InvalidArgumentError("label map '" + label_map.name +
                               "' holds no labelled voxel (every voxel is 0): nothing to mesh");
  }
  std::vector<int> wanted = options.labels.empty() ? present : options.labels;
  std::sort(wanted.begin(), wanted.end());
  wanted.erase(std::unique(wanted.begin(), wanted.end()), wanted.end());

  LabelMeshingResult result;
  result.scheme = options.scheme == LabelScheme::Auto ? detectLabelScheme(present) : options.scheme;
  const double voxel_ml = label_map.voxelVolume() / 1000.0;
  const double half_voxel = 0.5 * label_map.spacing.maxCoeff();

  for (int label : wanted) {
    if (boxes.find(label) == boxes.end() || label == 0) {
      std::string list;
      for (int p : present) list += (list.empty() ? "" : ", ") + std::to_string(p);
      throw InvalidArgumentError("label " + std::to_string(label) + " is empty in label map '" + label_map.name +
                                 "' (labels present: " + list + ")");
    }
  }
  // Labels are independent: each thread runs its own VTK pipelines on its own labels (a spine of ten
  // vertebrae meshes in about half the time on two cores).
  result.meshes.resize(wanted.size());
  parallelForBlocks(0, wanted.size(), [&](std::size_t begin, std::size_t end) {
    for (std::size_t w = begin; w < end; ++w) {
      result.meshes[w] = meshOneLabel(label_map, wanted[w], boxes.at(wanted[w]), result.scheme, options,
                                      voxel_ml, half_voxel);
    }
  });
  return result;
}

}  // namespace mrsns::registration
