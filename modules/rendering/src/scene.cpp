// The navigation scene: named objects, each a few actors sharing one pose
// matrix, updated in place so a frame costs a matrix copy or a point copy.
#include "mrsns/rendering/scene.h"

#include <vtkActor.h>
#include <vtkCamera.h>
#include <vtkCellArray.h>
#include <vtkDoubleArray.h>
#include <vtkFloatArray.h>
#include <vtkImageData.h>
#include <vtkLineSource.h>
#include <vtkLookupTable.h>
#include <vtkMatrix4x4.h>
#include <vtkPlaneSource.h>
#include <vtkPointData.h>
#include <vtkPoints.h>
#include <vtkPolyData.h>
#include <vtkPolyDataMapper.h>
#include <vtkProperty.h>
#include <vtkRenderer.h>
#include <vtkScalarBarActor.h>
#include <vtkSphereSource.h>
#include <vtkTextProperty.h>
#include <vtkTexture.h>
#include <vtkTubeFilter.h>

#include <cmath>
#include <map>

#include "lod.h"
#include "mrsns/core/error.h"
#include "mrsns/core/mesh_ops.h"
#include "mrsns/rendering/tool_models.h"
#include "vtk_convert.h"

namespace mrsns::rendering {
namespace {

enum class Kind { Mesh, Line, Polylines, ScrewPath, Tool, UltrasoundSlice };

struct Object {
  Kind kind = Kind::Mesh;
  std::vector<vtkSmartPointer<vtkActor>> actors;
  vtkSmartPointer<vtkMatrix4x4> world_T_object = vtkSmartPointer<vtkMatrix4x4>::New();
  bool visible = true;
  // Mesh and tool.
  vtkSmartPointer<vtkPolyData> full;
  vtkSmartPointer<vtkActor> full_actor;
  vtkSmartPointer<vtkActor> lod_actor;
  detail::DecimatedCopy lod;
  TriangleMesh rest;  ///< vertices the decimated copy was made from, and the faces
  bool has_scalars = false;
  // Line and screw path.
  vtkSmartPointer<vtkLineSource> line;
  vtkSmartPointer<vtkTubeFilter> tube;
  vtkSmartPointer<vtkSphereSource> entry_sphere;
  vtkSmartPointer<vtkSphereSource> target_sphere;
  // Ultrasound slice.
  vtkSmartPointer<vtkImageData> image;
  vtkSmartPointer<vtkPlaneSource> plane;
  vtkSmartPointer<vtkTexture> texture;
};

vtkSmartPointer<vtkActor> makeActor(vtkAlgorithmOutput* port, vtkPolyData* data, const Eigen::Vector3d& rgb,
                                    double opacity, vtkMatrix4x4* pose) {
  auto mapper = vtkSmartPointer<vtkPolyDataMapper>::New();
  if (port) {
    mapper->SetInputConnection(port);
  } else {
    mapper->SetInputData(data);
  }
  mapper->ScalarVisibilityOff();
  auto actor = vtkSmartPointer<vtkActor>::New();
  actor->SetMapper(mapper);
  actor->GetProperty()->SetColor(rgb.x(), rgb.y(), rgb.z());
  actor->GetProperty()->SetOpacity(opacity);
  actor->GetProperty()->SetSpecular(0.2);
  actor->SetUserMatrix(pose);
  return actor;
}

void checkName(const std::string& name) {
  if (name.empty()) throw InvalidArgumentError("scene object name is empty: give every object a name");
}

void checkPoint(const Eigen::Vector3d& p, const std::string& what) {
  if (!p.allFinite()) throw InvalidArgumentError(what + " is not finite (NaN or inf)");
}

}  // namespace

struct Scene::Impl {
  vtkSmartPointer<vtkRenderer> renderer = vtkSmartPointer<vtkRenderer>::New();
  std::map<std::string, Object> objects;
  vtkSmartPointer<vtkLookupTable> lut = vtkSmartPointer<vtkLookupTable>::New();
  vtkSmartPointer<vtkScalarBarActor> scalar_bar = vtkSmartPointer<vtkScalarBarActor>::New();
  DetailMode mode = DetailMode::Full;
  LodOptions lod_options;
  bool interacting = false;

  Impl() {
    renderer->SetBackground(0.08, 0.09, 0.12);
    // Blue (certain) to red (uncertain), the usual reading of a heat map.
    lut->SetHueRange(0.667, 0.0);
    lut->SetNumberOfTableValues(256);
    lut->Build();
    scalar_bar->SetLookupTable(lut);
    scalar_bar->SetNumberOfLabels(5);
    scalar_bar->SetPosition(0.88, 0.1);
    scalar_bar->SetWidth(0.1);
    scalar_bar->SetHeight(0.8);
    scalar_bar->GetTitleTextProperty()->SetFontSize(14);
    scalar_bar->SetVisibility(false);
    renderer->AddActor2D(scalar_bar);
  }

  bool decimated() const { return mode == DetailMode::Interactive || (mode == DetailMode::Automatic && interacting); }

  Object& get(const std::string& name) {
    const auto it = objects.find(name);
    if (it == objects.end()) {
      throw InvalidArgumentError("scene has no object '" + name + "': add it first (setMesh, setLine, setTool, ...)");
    }
    return it->second;
  }

  void applyVisibility(Object& o) const {
    if (o.lod_actor) {
      const bool use_lod = decimated();
      o.full_actor->SetVisibility(o.visible && !use_lod);
      o.lod_actor->SetVisibility(o.visible && use_lod);
    } else {
      for (auto& a : o.actors) a->SetVisibility(o.visible);
    }
  }

  void updateScalarBar() {
    bool any = false;
    for (const auto& [n, o] : objects) any = any || (o.has_scalars && o.visible);
    scalar_bar->SetVisibility(any);
  }

  Object& replace(const std::string& name, Kind kind) {
    checkName(name);
    // A replaced object keeps its place in the world.
    auto pose = vtkSmartPointer<vtkMatrix4x4>::New();
    if (const auto it = objects.find(name); it != objects.end()) pose->DeepCopy(it->second.world_T_object);
    removeObject(name);
    Object& o = objects[name];
    o.kind = kind;
    o.world_T_object = pose;
    return o;
  }

  void addActors(Object& o) {
    for (auto& a : o.actors) renderer->AddActor(a);
    applyVisibility(o);
  }

  void removeObject(const std::string& name) {
    const auto it = objects.find(name);
    if (it == objects.end()) return;
    for (auto& a : it->second.actors) renderer->RemoveActor(a);
    objects.erase(it);
    updateScalarBar();
  }

  void buildMesh(Object& o, const TriangleMesh& mesh, const Eigen::Vector3d& rgb, double opacity) {
    o.full = detail::toPolyData(mesh);
    o.rest = mesh;
    o.full_actor = makeActor(nullptr, o.full, rgb, opacity, o.world_T_object);
    o.actors = {o.full_actor};
    if (static_cast<std::size_t>(mesh.faceCount()) >= lod_options.min_triangles) {
      o.lod = detail::decimate(o.full, lod_options.keep_fraction);
      o.lod_actor = makeActor(nullptr, o.lod.poly, rgb, opacity, o.world_T_object);
      o.actors.push_back(o.lod_actor);
    }
    addActors(o);
  }
};

Scene::Scene() : impl_(std::make_unique<Impl>()) {}
Scene::~Scene() = default;

vtkRenderer* Scene::renderer() const {
  return impl_->renderer;
}

void Scene::setMesh(const std::string& name, const TriangleMesh& mesh, const Eigen::Vector3d& rgb, double opacity) {
  checkName(name);
  if (mesh.empty()) throw InvalidArgumentError("mesh '" + name + "' has no vertices or no faces: nothing to draw");
  validateMesh(mesh, "mesh '" + name + "'");
  detail::checkColor(rgb, "mesh '" + name + "'");
  if (!(opacity >= 0.0 && opacity <= 1.0)) {
    throw InvalidArgumentError("mesh '" + name + "': opacity must lie in [0, 1]");
  }
  const auto it = impl_->objects.find(name);
  if (it != impl_->objects.end() && it->second.kind == Kind::Mesh &&
      it->second.rest.vertexCount() == mesh.vertexCount() && it->second.rest.faces == mesh.faces) {
    // Same topology: move the points, keep the pipeline (and the pose).
    Object& o = it->second;
    for (auto& a : o.actors) {
      a->GetProperty()->SetColor(rgb.x(), rgb.y(), rgb.z());
      a->GetProperty()->SetOpacity(opacity);
    }
    updateMeshVertices(name, mesh.vertices);
    return;
  }
  Object& o = impl_->replace(name, Kind::Mesh);
  impl_->buildMesh(o, mesh, rgb, opacity);
}

void Scene::updateMeshVertices(const std::string& name,
                               const Eigen::Matrix<double, Eigen::Dynamic, 3, Eigen::RowMajor>& vertices) {
  Object& o = impl_->get(name);
  if (!o.full || o.kind != Kind::Mesh) throw InvalidArgumentError("scene object '" + name + "' is not a mesh");
  if (vertices.rows() != o.rest.vertexCount()) {
    throw InvalidArgumentError("mesh '" + name + "' has " + std::to_string(o.rest.vertexCount()) + " vertices, " +
                               std::to_string(vertices.rows()) + " given: use setMesh to change the topology");
  }
  if (!vertices.allFinite()) throw InvalidArgumentError("mesh '" + name + "': new vertices hold NaN or inf");
  detail::setPoints(o.full, vertices);
  TriangleMesh now;
  now.vertices = vertices;
  now.faces = o.rest.faces;
  const detail::PointsN3 normals = vertexNormals(now);
  auto* n = vtkFloatArray::SafeDownCast(o.full->GetPointData()->GetNormals());
  if (n) {
    for (Eigen::Index i = 0; i < normals.rows(); ++i) n->SetTuple3(i, normals(i, 0), normals(i, 1), normals(i, 2));
    n->Modified();
  }
  if (o.lod.poly) detail::followDeformation(o.lod, o.rest.vertices, vertices);
}

void Scene::setMeshScalars(const std::string& name, const std::vector<double>& per_vertex, double lo, double hi,
                           const std::string& title) {
  Object& o = impl_->get(name);
  if (!o.full || o.kind != Kind::Mesh) throw InvalidArgumentError("scene object '" + name + "' is not a mesh");
  if (static_cast<Eigen::Index>(per_vertex.size()) != o.rest.vertexCount()) {
    throw InvalidArgumentError("mesh '" + name + "' has " + std::to_string(o.rest.vertexCount()) + " vertices but " +
                               std::to_string(per_vertex.size()) + " scalars were given: give one per vertex");
  }
  if (!std::isfinite(lo) || !std::isfinite(hi) || !(lo < hi)) {
    throw InvalidArgumentError("scalar range [" + std::to_string(lo) + ", " + std::to_string(hi) + "] of mesh '" +
                               name + "': need finite lo < hi");
  }
  for (double v : per_vertex) {
    if (!std::isfinite(v)) throw InvalidArgumentError("scalars of mesh '" + name + "' hold NaN or inf");
  }
  auto fill = [&](vtkPolyData* poly, auto&& value_of) {
    auto array = vtkDoubleArray::SafeDownCast(poly->GetPointData()->GetScalars());
    if (!array || array->GetNumberOfTuples() != poly->GetNumberOfPoints()) {
      auto fresh = vtkSmartPointer<vtkDoubleArray>::New();
      fresh->SetName("Scalars");
      fresh->SetNumberOfTuples(poly->GetNumberOfPoints());
      poly->GetPointData()->SetScalars(fresh);
      array = fresh;
    }
    for (vtkIdType i = 0; i < poly->GetNumberOfPoints(); ++i) array->SetValue(i, value_of(i));
    array->Modified();
  };
  fill(o.full, [&](vtkIdType i) { return per_vertex[static_cast<std::size_t>(i)]; });
  if (o.lod.poly) {
    fill(o.lod.poly,
         [&](vtkIdType i) { return per_vertex[static_cast<std::size_t>(o.lod.source[static_cast<std::size_t>(i)])]; });
  }
  impl_->lut->SetTableRange(lo, hi);
  for (auto& a : o.actors) {
    auto* mapper = a->GetMapper();
    mapper->SetLookupTable(impl_->lut);
    mapper->SetScalarRange(lo, hi);
    mapper->SetScalarModeToUsePointData();
    mapper->ScalarVisibilityOn();
  }
  impl_->scalar_bar->SetTitle(title.c_str());
  o.has_scalars = true;
  impl_->updateScalarBar();
}

void Scene::clearMeshScalars(const std::string& name) {
  Object& o = impl_->get(name);
  for (auto& a : o.actors) a->GetMapper()->ScalarVisibilityOff();
  o.has_scalars = false;
  impl_->updateScalarBar();
}

void Scene::setPose(const std::string& name, const Eigen::Isometry3d& world_T_object) {
  Object& o = impl_->get(name);
  if (!world_T_object.matrix().allFinite()) {
    throw InvalidArgumentError("pose of '" + name + "' holds NaN or inf");
  }
  detail::copyInto(world_T_object.matrix(), o.world_T_object);
}

void Scene::setLine(const std::string& name, const Eigen::Vector3d& a, const Eigen::Vector3d& b,
                    const Eigen::Vector3d& rgb) {
  checkName(name);
  checkPoint(a, "line '" + name + "' start");
  checkPoint(b, "line '" + name + "' end");
  detail::checkColor(rgb, "line '" + name + "'");
  auto it = impl_->objects.find(name);
  if (it == impl_->objects.end() || it->second.kind != Kind::Line) {
    Object& o = impl_->replace(name, Kind::Line);
    o.line = vtkSmartPointer<vtkLineSource>::New();
    auto actor = makeActor(o.line->GetOutputPort(), nullptr, rgb, 1.0, o.world_T_object);
    actor->GetProperty()->SetLineWidth(3.0);
    actor->GetProperty()->LightingOff();
    o.actors = {actor};
    impl_->addActors(o);
    it = impl_->objects.find(name);
  }
  Object& o = it->second;
  o.line->SetPoint1(a.data());
  o.line->SetPoint2(b.data());
  o.actors.front()->GetProperty()->SetColor(rgb.x(), rgb.y(), rgb.z());
}

void Scene::setPolylines(const std::string& name, const std::vector<Polyline3d>& lines, const Eigen::Vector3d& rgb) {
  checkName(name);
  detail::checkColor(rgb, "polylines '" + name + "'");
  auto points = vtkSmartPointer<vtkPoints>::New();
  auto cells = vtkSmartPointer<vtkCellArray>::New();
  for (const auto& line : lines) {
    if (line.points.size() < 2) continue;
    const vtkIdType first = points->GetNumberOfPoints();
    for (const auto& p : line.points) {
      checkPoint(p, "polylines '" + name + "' point");
      points->InsertNextPoint(p.data());
    }
    const auto n = static_cast<vtkIdType>(line.points.size());
    cells->InsertNextCell(line.closed ? n + 1 : n);
    for (vtkIdType i = 0; i < n; ++i) cells->InsertCellPoint(first + i);
    if (line.closed) cells->InsertCellPoint(first);
  }
  auto poly = vtkSmartPointer<vtkPolyData>::New();
  poly->SetPoints(points);
  poly->SetLines(cells);
  auto it = impl_->objects.find(name);
  if (it == impl_->objects.end() || it->second.kind != Kind::Polylines) {
    Object& o = impl_->replace(name, Kind::Polylines);
    auto actor = makeActor(nullptr, poly, rgb, 1.0, o.world_T_object);
    actor->GetProperty()->SetLineWidth(2.0);
    actor->GetProperty()->LightingOff();
    // An outline lies in the plane of the frame it was found in: drawn in front of it, not half hidden.
    if (auto* mapper = vtkPolyDataMapper::SafeDownCast(actor->GetMapper())) {
      mapper->SetResolveCoincidentTopologyToPolygonOffset();
      mapper->SetRelativeCoincidentTopologyLineOffsetParameters(-2.0, -20.0);
    }
    o.actors = {actor};
    impl_->addActors(o);
    return;
  }
  Object& o = it->second;
  vtkPolyDataMapper::SafeDownCast(o.actors.front()->GetMapper())->SetInputData(poly);
  o.actors.front()->GetProperty()->SetColor(rgb.x(), rgb.y(), rgb.z());
}

void Scene::setScrewPath(const std::string& name, const Eigen::Vector3d& entry, const Eigen::Vector3d& target,
                         double diameter_mm, const Eigen::Vector3d& rgb) {
  checkName(name);
  checkPoint(entry, "screw path '" + name + "' entry");
  checkPoint(target, "screw path '" + name + "' target");
  detail::checkColor(rgb, "screw path '" + name + "'");
  if ((target - entry).norm() < 1e-6) {
    throw InvalidArgumentError("screw path '" + name + "': entry and target coincide; plan a path of non-zero length");
  }
  if (!(diameter_mm > 0.0 && diameter_mm < 50.0)) {
    throw InvalidArgumentError("screw path '" + name + "': diameter must lie in (0, 50) mm");
  }
  auto it = impl_->objects.find(name);
  if (it == impl_->objects.end() || it->second.kind != Kind::ScrewPath) {
    Object& o = impl_->replace(name, Kind::ScrewPath);
    o.line = vtkSmartPointer<vtkLineSource>::New();
    o.tube = vtkSmartPointer<vtkTubeFilter>::New();
    o.tube->SetInputConnection(o.line->GetOutputPort());
    o.tube->SetNumberOfSides(16);
    o.tube->CappingOn();
    o.entry_sphere = vtkSmartPointer<vtkSphereSource>::New();
    o.target_sphere = vtkSmartPointer<vtkSphereSource>::New();
    for (auto* s : {o.entry_sphere.Get(), o.target_sphere.Get()}) {
      s->SetThetaResolution(16);
      s->SetPhiResolution(12);
    }
    o.actors = {makeActor(o.tube->GetOutputPort(), nullptr, rgb, 1.0, o.world_T_object),
                makeActor(o.entry_sphere->GetOutputPort(), nullptr, rgb, 1.0, o.world_T_object),
                makeActor(o.target_sphere->GetOutputPort(), nullptr, rgb, 1.0, o.world_T_object)};
    impl_->addActors(o);
    it = impl_->objects.find(name);
  }
  Object& o = it->second;
  o.line->SetPoint1(entry.data());
  o.line->SetPoint2(target.data());
  o.tube->SetRadius(diameter_mm / 2.0);
  // Entry larger than target so the direction reads at a glance.
  o.entry_sphere->SetCenter(entry.data());
  o.entry_sphere->SetRadius(0.9 * diameter_mm);
  o.target_sphere->SetCenter(target.data());
  o.target_sphere->SetRadius(0.65 * diameter_mm);
  for (auto& a : o.actors) a->GetProperty()->SetColor(rgb.x(), rgb.y(), rgb.z());
}

void Scene::setTool(const std::string& name, ToolKind kind, const Eigen::Vector3d& rgb) {
  checkName(name);
  detail::checkColor(rgb, "tool '" + name + "'");
  Object& o = impl_->replace(name, Kind::Tool);
  impl_->buildMesh(o, toolModel(kind), rgb, 1.0);
}

void Scene::setUltrasoundSlice(const std::string& name, const ImageVolume& frame_2d,
                               const Eigen::Isometry3d& world_T_image) {
  detail::checkImage(frame_2d, "ultrasound frame '" + name + "'");
  Eigen::Matrix4d image_T_pixel = frame_2d.ijkToLps();
  setUltrasoundSlice(name, frame_2d, Eigen::Matrix4d(world_T_image.matrix() * image_T_pixel));
}

void Scene::setUltrasoundSlice(const std::string& name, const ImageVolume& frame_2d,
                               const Eigen::Matrix4d& world_T_pixel) {
  checkName(name);
  detail::checkImage(frame_2d, "ultrasound frame '" + name + "'");
  if (frame_2d.size[2] != 1) {
    throw InvalidArgumentError("ultrasound frame '" + name + "' has " + std::to_string(frame_2d.size[2]) +
                               " slices: give one 2D frame (size[2] == 1)");
  }
  if (!world_T_pixel.allFinite())
    throw InvalidArgumentError("placement of ultrasound frame '" + name + "' is not finite");
  auto it = impl_->objects.find(name);
  if (it == impl_->objects.end() || it->second.kind != Kind::UltrasoundSlice) {
    Object& o = impl_->replace(name, Kind::UltrasoundSlice);
    o.plane = vtkSmartPointer<vtkPlaneSource>::New();
    o.texture = vtkSmartPointer<vtkTexture>::New();
    o.texture->InterpolateOn();
    o.texture->SetColorModeToDirectScalars();
    auto actor = makeActor(o.plane->GetOutputPort(), nullptr, Eigen::Vector3d::Ones(), 1.0, o.world_T_object);
    // The grey levels are the data: no shading on the plane.
    actor->GetProperty()->LightingOff();
    actor->SetTexture(o.texture);
    o.actors = {actor};
    impl_->addActors(o);
    it = impl_->objects.find(name);
  }
  Object& o = it->second;
  vtkImageData* before = o.image;
  o.image = detail::greyFrame(frame_2d, o.image);
  if (o.image.Get() != before) o.texture->SetInputData(o.image);
  o.texture->Modified();
  // Pixel centres run 0..n-1; the texture covers the pixels' full area.
  auto corner = [&](double i, double j) {
    const Eigen::Vector4d p = world_T_pixel * Eigen::Vector4d(i, j, 0.0, 1.0);
    return Eigen::Vector3d(p.head<3>());
  };
  const double w = frame_2d.size[0] - 0.5;
  const double h = frame_2d.size[1] - 0.5;
  const Eigen::Vector3d origin = corner(-0.5, -0.5);
  Eigen::Vector3d p1 = corner(w, -0.5);
  Eigen::Vector3d p2 = corner(-0.5, h);
  o.plane->SetOrigin(origin.data());
  o.plane->SetPoint1(p1.data());
  o.plane->SetPoint2(p2.data());
}

void Scene::setVisible(const std::string& name, bool visible) {
  Object& o = impl_->get(name);
  o.visible = visible;
  impl_->applyVisibility(o);
  impl_->updateScalarBar();
}

bool Scene::contains(const std::string& name) const {
  return impl_->objects.count(name) != 0;
}

std::vector<std::string> Scene::names() const {
  std::vector<std::string> out;
  for (const auto& [n, o] : impl_->objects) out.push_back(n);
  return out;
}

void Scene::remove(const std::string& name) {
  impl_->removeObject(name);
}

void Scene::clear() {
  while (!impl_->objects.empty()) impl_->removeObject(impl_->objects.begin()->first);
}

void Scene::resetCamera() {
  // Anterior view (LPS: from -y), superior up: how the surgeon faces a supine neck.
  vtkCamera* camera = impl_->renderer->GetActiveCamera();
  camera->SetFocalPoint(0.0, 0.0, 0.0);
  camera->SetPosition(0.0, -1.0, 0.0);
  camera->SetViewUp(0.0, 0.0, 1.0);
  impl_->renderer->ResetCamera();
}

void Scene::setCamera(const Eigen::Vector3d& position, const Eigen::Vector3d& focal_point,
                      const Eigen::Vector3d& view_up) {
  checkPoint(position, "camera position");
  checkPoint(focal_point, "camera focal point");
  if ((position - focal_point).norm() < 1e-9 || view_up.cross(position - focal_point).norm() < 1e-9) {
    throw InvalidArgumentError("camera: position equals the focal point or view-up is parallel to the view direction");
  }
  vtkCamera* camera = impl_->renderer->GetActiveCamera();
  camera->SetPosition(position.data());
  camera->SetFocalPoint(focal_point.data());
  camera->SetViewUp(view_up.data());
  impl_->renderer->ResetCameraClippingRange();
}

void Scene::setBackground(const Eigen::Vector3d& rgb) {
  detail::checkColor(rgb, "background");
  impl_->renderer->SetBackground(rgb.x(), rgb.y(), rgb.z());
}

void Scene::setDetailMode(DetailMode mode) {
  impl_->mode = mode;
  for (auto& [n, o] : impl_->objects) impl_->applyVisibility(o);
}

DetailMode Scene::detailMode() const {
  return impl_->mode;
}

void Scene::setInteracting(bool interacting) {
  impl_->interacting = interacting;
  for (auto& [n, o] : impl_->objects) impl_->applyVisibility(o);
}

bool Scene::drawingDecimated() const {
  return impl_->decimated();
}

void Scene::setLodOptions(const LodOptions& options) {
  if (!(options.keep_fraction > 0.0 && options.keep_fraction <= 1.0)) {
    throw InvalidArgumentError("LOD keep_fraction must lie in (0, 1]");
  }
  // Applies to meshes set from now on; existing copies stay.
  impl_->lod_options = options;
}

SceneStats Scene::stats() const {
  SceneStats s;
  s.objects = impl_->objects.size();
  for (const auto& [n, o] : impl_->objects) {
    if (!o.visible || !o.full) continue;
    const auto full = static_cast<std::size_t>(o.full->GetNumberOfPolys());
    s.triangles_full += full;
    s.triangles_interactive += o.lod.poly ? static_cast<std::size_t>(o.lod.poly->GetNumberOfPolys()) : full;
  }
  return s;
}

}  // namespace mrsns::rendering
