// Three orthogonal reslices of a CT through a cursor, each a parallel camera
// whose focal point is the cursor: vtkImageResliceMapper cuts the volume at
// the focal plane facing the camera, so moving the cursor is a camera move.
#include "mrsns/rendering/slice_views.h"

#include <vtkActor.h>
#include <vtkCamera.h>
#include <vtkCellArray.h>
#include <vtkCellData.h>
#include <vtkPoints.h>
#include <vtkPolyData.h>
#include <vtkRenderWindow.h>
#include <vtkUnsignedCharArray.h>
#include <vtkImageData.h>
#include <vtkImageProperty.h>
#include <vtkImageResliceMapper.h>
#include <vtkImageSlice.h>
#include <vtkLineSource.h>
#include <vtkMatrix4x4.h>
#include <vtkNew.h>
#include <vtkPolyDataMapper.h>
#include <vtkProperty.h>
#include <vtkRenderer.h>
#include <vtkSphereSource.h>

#include <algorithm>
#include <cmath>
#include <numbers>

#include "mrsns/core/error.h"
#include "offscreen.h"
#include "vtk_convert.h"

namespace mrsns::rendering {
namespace {

struct ViewAxes {
  Eigen::Vector3d normal;  ///< direction of projection (from the camera into the scene)
  Eigen::Vector3d up;
};

// Radiological convention (see SliceOrientation).
ViewAxes axesOf(SliceOrientation view) {
  switch (view) {
    case SliceOrientation::Axial: return {Eigen::Vector3d::UnitZ(), -Eigen::Vector3d::UnitY()};
    case SliceOrientation::Sagittal: return {-Eigen::Vector3d::UnitX(), Eigen::Vector3d::UnitZ()};
    case SliceOrientation::Coronal: return {Eigen::Vector3d::UnitY(), Eigen::Vector3d::UnitZ()};
  }
  return {Eigen::Vector3d::UnitZ(), -Eigen::Vector3d::UnitY()};
}

// Overlays sit this far in front of the slice so the image does not hide them.
constexpr double kOverlayLift_mm = 1.0;
constexpr double kCameraDistance_mm = 1000.0;

struct Overlay {
  vtkSmartPointer<vtkLineSource> tool_line = vtkSmartPointer<vtkLineSource>::New();
  vtkSmartPointer<vtkSphereSource> tool_tip = vtkSmartPointer<vtkSphereSource>::New();
  vtkSmartPointer<vtkLineSource> us_line = vtkSmartPointer<vtkLineSource>::New();
  vtkSmartPointer<vtkActor> tool_line_actor = vtkSmartPointer<vtkActor>::New();
  vtkSmartPointer<vtkActor> tool_tip_actor = vtkSmartPointer<vtkActor>::New();
  vtkSmartPointer<vtkActor> us_actor = vtkSmartPointer<vtkActor>::New();
};

vtkSmartPointer<vtkActor> overlayActor(vtkActor* actor, vtkAlgorithmOutput* port, const Eigen::Vector3d& rgb) {
  auto mapper = vtkSmartPointer<vtkPolyDataMapper>::New();
  mapper->SetInputConnection(port);
  actor->SetMapper(mapper);
  actor->GetProperty()->SetColor(rgb.x(), rgb.y(), rgb.z());
  actor->GetProperty()->LightingOff();
  actor->GetProperty()->SetLineWidth(2.0);
  actor->SetVisibility(false);
  return actor;
}

/// Coloured polylines in one actor, rebuilt whenever what they show changes (a few hundred points at most).
class LineLayer {
 public:
  explicit LineLayer(double width) {
    mapper_->SetInputData(poly_);
    mapper_->SetScalarModeToUseCellData();
    mapper_->SetColorModeToDirectScalars();
    mapper_->ScalarVisibilityOn();
    actor_->SetMapper(mapper_);
    actor_->GetProperty()->LightingOff();
    actor_->GetProperty()->SetLineWidth(static_cast<float>(width));
  }
  vtkActor* actor() const { return actor_; }
  void clear() {
    points_.clear();
    cells_.clear();
  }
  void polyline(const std::vector<Eigen::Vector3d>& points, const Eigen::Vector3d& rgb, bool closed = false) {
    if (points.size() < 2) return;
    Cell cell;
    for (const auto& p : points) {
      cell.ids.push_back(static_cast<vtkIdType>(points_.size()));
      points_.push_back(p);
    }
    if (closed) cell.ids.push_back(cell.ids.front());
    cell.rgb = rgb;
    cells_.push_back(std::move(cell));
  }
  void line(const Eigen::Vector3d& a, const Eigen::Vector3d& b, const Eigen::Vector3d& rgb) { polyline({a, b}, rgb); }
  void circle(const Eigen::Vector3d& centre, const Eigen::Vector3d& u, const Eigen::Vector3d& v, double radius,
              const Eigen::Vector3d& rgb) {
    std::vector<Eigen::Vector3d> ring;
    constexpr int kSegments = 24;
    for (int k = 0; k < kSegments; ++k) {
      const double t = 2.0 * std::numbers::pi * k / kSegments;
      ring.push_back(centre + radius * (std::cos(t) * u + std::sin(t) * v));
    }
    polyline(ring, rgb, true);
  }
  void commit() {
    vtkNew<vtkPoints> points;
    points->SetNumberOfPoints(static_cast<vtkIdType>(points_.size()));
    for (std::size_t i = 0; i < points_.size(); ++i) points->SetPoint(static_cast<vtkIdType>(i), points_[i].data());
    vtkNew<vtkCellArray> lines;
    vtkNew<vtkUnsignedCharArray> colors;
    colors->SetNumberOfComponents(3);
    for (const auto& c : cells_) {
      lines->InsertNextCell(static_cast<vtkIdType>(c.ids.size()), c.ids.data());
      const auto byte = [](double x) { return static_cast<unsigned char>(std::clamp(x, 0.0, 1.0) * 255.0 + 0.5); };
      const unsigned char rgb[3] = {byte(c.rgb.x()), byte(c.rgb.y()), byte(c.rgb.z())};
      colors->InsertNextTypedTuple(rgb);
    }
    poly_->SetPoints(points);
    poly_->SetLines(lines);
    poly_->GetCellData()->SetScalars(colors);
    poly_->Modified();
    actor_->SetVisibility(!cells_.empty());
  }

 private:
  struct Cell {
    std::vector<vtkIdType> ids;
    Eigen::Vector3d rgb;
  };
  std::vector<Eigen::Vector3d> points_;
  std::vector<Cell> cells_;
  vtkSmartPointer<vtkPolyData> poly_ = vtkSmartPointer<vtkPolyData>::New();
  vtkSmartPointer<vtkPolyDataMapper> mapper_ = vtkSmartPointer<vtkPolyDataMapper>::New();
  vtkSmartPointer<vtkActor> actor_ = vtkSmartPointer<vtkActor>::New();
};

// Slicer's view colours: the axial plane red, sagittal yellow, coronal green.
const Eigen::Vector3d kViewColor[3] = {{0.93, 0.33, 0.33}, {0.93, 0.86, 0.33}, {0.40, 0.80, 0.40}};

/// Any unit vector perpendicular to `a`.
Eigen::Vector3d perpendicular(const Eigen::Vector3d& a) {
  const Eigen::Vector3d helper = std::abs(a.z()) < 0.9 ? Eigen::Vector3d::UnitZ() : Eigen::Vector3d::UnitY();
  return a.cross(helper).normalized();
}

}  // namespace

struct SliceViews::Impl {
  std::array<vtkSmartPointer<vtkRenderer>, 3> renderers;
  std::array<vtkSmartPointer<vtkImageSlice>, 3> slices;
  std::array<Overlay, 3> overlays;
  vtkSmartPointer<vtkImageProperty> property = vtkSmartPointer<vtkImageProperty>::New();
  vtkSmartPointer<vtkImageData> image;
  vtkSmartPointer<vtkMatrix4x4> lps_T_index;
  Eigen::AlignedBox3d bounds;
  Eigen::Vector3d cursor = Eigen::Vector3d::Zero();
  double window = 400.0;
  double level = 40.0;
  bool has_tool = false;
  Eigen::Vector3d tool_tip = Eigen::Vector3d::Zero();
  Eigen::Vector3d tool_end = Eigen::Vector3d::Zero();
  bool has_us = false;
  std::array<Eigen::Vector3d, 4> us_corners;  ///< CT mm, around the frame's edge
  bool crosshair = false;
  Eigen::Vector3d spacing = Eigen::Vector3d::Ones();
  Eigen::Matrix3d direction = Eigen::Matrix3d::Identity();
  std::vector<SliceScrew> screws;
  std::vector<SliceMarker> markers;
  std::array<std::unique_ptr<LineLayer>, 3> crosshair_layers;
  std::array<std::unique_ptr<LineLayer>, 3> screw_layers;
  std::array<std::unique_ptr<LineLayer>, 3> marker_layers;
  // The trajectory views.
  std::array<vtkSmartPointer<vtkRenderer>, 2> trajectory_renderers;
  std::array<vtkSmartPointer<vtkImageSlice>, 2> trajectory_slices;
  std::array<std::unique_ptr<LineLayer>, 2> trajectory_layers;
  bool has_trajectory = false;

  Impl() {
    property->SetColorWindow(window);
    property->SetColorLevel(level);
    property->SetInterpolationTypeToLinear();
    for (std::size_t v = 0; v < 3; ++v) {
      renderers[v] = vtkSmartPointer<vtkRenderer>::New();
      renderers[v]->SetBackground(0.0, 0.0, 0.0);
      renderers[v]->GetActiveCamera()->ParallelProjectionOn();
      Overlay& o = overlays[v];
      o.tool_tip->SetRadius(1.5);
      overlayActor(o.tool_line_actor, o.tool_line->GetOutputPort(), Eigen::Vector3d(0.2, 1.0, 0.2));
      overlayActor(o.tool_tip_actor, o.tool_tip->GetOutputPort(), Eigen::Vector3d(0.2, 1.0, 0.2));
      overlayActor(o.us_actor, o.us_line->GetOutputPort(), Eigen::Vector3d(1.0, 0.85, 0.1));
      for (auto* a : {o.tool_line_actor.Get(), o.tool_tip_actor.Get(), o.us_actor.Get()}) renderers[v]->AddActor(a);
      crosshair_layers[v] = std::make_unique<LineLayer>(1.0);
      screw_layers[v] = std::make_unique<LineLayer>(2.0);
      marker_layers[v] = std::make_unique<LineLayer>(2.0);
      for (const auto& layer : {crosshair_layers[v].get(), screw_layers[v].get(), marker_layers[v].get()}) {
        renderers[v]->AddActor(layer->actor());
      }
    }
    for (std::size_t t = 0; t < 2; ++t) {
      trajectory_renderers[t] = vtkSmartPointer<vtkRenderer>::New();
      trajectory_renderers[t]->SetBackground(0.0, 0.0, 0.0);
      trajectory_renderers[t]->GetActiveCamera()->ParallelProjectionOn();
      trajectory_layers[t] = std::make_unique<LineLayer>(2.0);
      trajectory_renderers[t]->AddActor(trajectory_layers[t]->actor());
    }
  }

  /// The CT's voxel size along `view`'s normal.
  double stepAlong(std::size_t v) const {
    const Eigen::Vector3d n = axesOf(static_cast<SliceOrientation>(v)).normal;
    // The voxel's extent along n: the sum of its edges' projections, as near as a direction matrix allows.
    double step = 0.0;
    for (int a = 0; a < 3; ++a) step += std::abs(n.dot(direction.col(a))) * spacing[a];
    return std::max(step, 1e-3);
  }

  void updateCrosshair(std::size_t v) {
    LineLayer& layer = *crosshair_layers[v];
    layer.clear();
    if (crosshair && image) {
      const Eigen::Vector3d n = axesOf(static_cast<SliceOrientation>(v)).normal;
      const double half = 0.5 * (bounds.isEmpty() ? 500.0 : bounds.diagonal().norm());
      for (std::size_t w = 0; w < 3; ++w) {
        if (w == v) continue;
        const Eigen::Vector3d d = n.cross(axesOf(static_cast<SliceOrientation>(w)).normal).normalized();
        layer.line(onPlane(v, cursor - half * d), onPlane(v, cursor + half * d), kViewColor[w]);
      }
    }
    layer.commit();
  }

  void updateScrews(std::size_t v) {
    LineLayer& layer = *screw_layers[v];
    layer.clear();
    const Eigen::Vector3d n = axesOf(static_cast<SliceOrientation>(v)).normal;
    for (const auto& screw : screws) {
      const Eigen::Vector3d rgb = screw.selected ? Eigen::Vector3d(1.0, 0.85, 0.2) : screw.rgb;
      const Eigen::Vector3d a = onPlane(v, screw.entry), b = onPlane(v, screw.tip);
      const double r = 0.5 * screw.diameter_mm;
      const Eigen::Vector3d u = b - a;
      if (u.norm() < 1e-6) {
        // Seen end on: the screw's cross-section.
        layer.circle(a, perpendicular(n), n.cross(perpendicular(n)), r, rgb);
      } else {
        const Eigen::Vector3d w = n.cross(u).normalized();
        layer.polyline({a + r * w, b + r * w, b - r * w, a - r * w}, rgb, true);
        layer.line(a, b, rgb);
      }
      const double handle = std::max(2.0, r + 1.0);
      layer.circle(a, perpendicular(n), n.cross(perpendicular(n)), handle, rgb);
      layer.circle(b, perpendicular(n), n.cross(perpendicular(n)), 0.6 * handle, rgb);
    }
    layer.commit();
  }

  void updateMarkers(std::size_t v) {
    LineLayer& layer = *marker_layers[v];
    layer.clear();
    const ViewAxes ax = axesOf(static_cast<SliceOrientation>(v));
    const Eigen::Vector3d right = ax.up.cross(ax.normal);
    const double slab = 0.5 * stepAlong(v);
    for (const auto& m : markers) {
      const bool in_plane = std::abs((m.position - cursor).dot(ax.normal)) <= slab;
      const double arm = in_plane ? 4.0 : 2.0;
      const Eigen::Vector3d rgb = in_plane ? m.rgb : 0.6 * m.rgb;
      const Eigen::Vector3d c = onPlane(v, m.position);
      layer.line(c - arm * right, c + arm * right, rgb);
      layer.line(c - arm * ax.up, c + arm * ax.up, rgb);
    }
    layer.commit();
  }

  // Points on the slice plane, lifted towards the camera.
  Eigen::Vector3d onPlane(std::size_t v, const Eigen::Vector3d& p) const {
    const ViewAxes ax = axesOf(static_cast<SliceOrientation>(v));
    return p - (p - cursor).dot(ax.normal) * ax.normal - kOverlayLift_mm * ax.normal;
  }

  void place(std::size_t v) {
    const ViewAxes ax = axesOf(static_cast<SliceOrientation>(v));
    vtkCamera* camera = renderers[v]->GetActiveCamera();
    const double scale = camera->GetParallelScale();
    camera->SetFocalPoint(cursor.data());
    const Eigen::Vector3d eye = cursor - kCameraDistance_mm * ax.normal;
    camera->SetPosition(eye.data());
    camera->SetViewUp(ax.up.data());
    camera->SetParallelScale(scale);
    renderers[v]->ResetCameraClippingRange();
    updateOverlays(v);
    updateCrosshair(v);
    updateScrews(v);
    updateMarkers(v);
  }

  void updateOverlays(std::size_t v) {
    Overlay& o = overlays[v];
    o.tool_line_actor->SetVisibility(has_tool);
    o.tool_tip_actor->SetVisibility(has_tool);
    if (has_tool) {
      const Eigen::Vector3d a = onPlane(v, tool_tip);
      const Eigen::Vector3d b = onPlane(v, tool_end);
      o.tool_line->SetPoint1(a.data());
      o.tool_line->SetPoint2(b.data());
      o.tool_tip->SetCenter(a.data());
    }
    Eigen::Vector3d a;
    Eigen::Vector3d b;
    const bool cut = intersect(v, a, b);
    o.us_actor->SetVisibility(cut);
    if (cut) {
      const Eigen::Vector3d la = onPlane(v, a);
      const Eigen::Vector3d lb = onPlane(v, b);
      o.us_line->SetPoint1(la.data());
      o.us_line->SetPoint2(lb.data());
    }
  }

  bool intersect(std::size_t v, Eigen::Vector3d& a, Eigen::Vector3d& b) const {
    if (!has_us) return false;
    const Eigen::Vector3d n = axesOf(static_cast<SliceOrientation>(v)).normal;
    std::vector<Eigen::Vector3d> hits;
    for (std::size_t e = 0; e < 4; ++e) {
      const Eigen::Vector3d& p = us_corners[e];
      const Eigen::Vector3d& q = us_corners[(e + 1) % 4];
      const double dp = (p - cursor).dot(n);
      const double dq = (q - cursor).dot(n);
      // Half-open test (>= 0 on one side) so a corner on the plane counts once.
      if ((dp >= 0.0) == (dq >= 0.0)) continue;
      hits.push_back(p + dp / (dp - dq) * (q - p));
    }
    if (hits.size() < 2) return false;
    a = hits[0];
    b = hits[1];
    return (a - b).norm() > 1e-9;
  }
};

SliceViews::SliceViews() : impl_(std::make_unique<Impl>()) {}
SliceViews::~SliceViews() = default;

void SliceViews::setVolume(const ImageVolume& ct) {
  detail::checkImage(ct, "CT volume '" + ct.name + "'");
  impl_->image = detail::toImageData(ct);
  impl_->lps_T_index = detail::indexToLpsMatrix(ct);
  impl_->bounds.setEmpty();
  for (int c = 0; c < 8; ++c) {
    const Eigen::Vector3d ijk((c & 1) ? ct.size[0] - 1 : 0, (c & 2) ? ct.size[1] - 1 : 0, (c & 4) ? ct.size[2] - 1 : 0);
    impl_->bounds.extend(ct.indexToPhysical(ijk));
  }
  for (std::size_t v = 0; v < 3; ++v) {
    auto mapper = vtkSmartPointer<vtkImageResliceMapper>::New();
    mapper->SetInputData(impl_->image);
    mapper->SliceFacesCameraOn();
    mapper->SliceAtFocalPointOn();
    auto slice = vtkSmartPointer<vtkImageSlice>::New();
    slice->SetMapper(mapper);
    slice->SetProperty(impl_->property);
    // The volume's direction and origin go into the prop: the mapper reslices
    // through any prop matrix, so oblique CTs come out LPS-aligned.
    slice->SetUserMatrix(impl_->lps_T_index);
    if (impl_->slices[v]) impl_->renderers[v]->RemoveViewProp(impl_->slices[v]);
    impl_->slices[v] = slice;
    impl_->renderers[v]->AddViewProp(slice);
  }
  for (std::size_t t = 0; t < 2; ++t) {
    auto mapper = vtkSmartPointer<vtkImageResliceMapper>::New();
    mapper->SetInputData(impl_->image);
    mapper->SliceFacesCameraOn();
    mapper->SliceAtFocalPointOn();
    auto slice = vtkSmartPointer<vtkImageSlice>::New();
    slice->SetMapper(mapper);
    slice->SetProperty(impl_->property);
    slice->SetUserMatrix(impl_->lps_T_index);
    if (impl_->trajectory_slices[t]) impl_->trajectory_renderers[t]->RemoveViewProp(impl_->trajectory_slices[t]);
    impl_->trajectory_slices[t] = slice;
    impl_->trajectory_renderers[t]->AddViewProp(slice);
  }
  impl_->spacing = ct.spacing;
  impl_->direction = ct.direction;
  impl_->cursor = impl_->bounds.center();
  setWindowLevel(400.0, 40.0);
  resetCameras();
}

void SliceViews::clearVolume() {
  for (std::size_t v = 0; v < 3; ++v) {
    if (impl_->slices[v]) impl_->renderers[v]->RemoveViewProp(impl_->slices[v]);
    impl_->slices[v] = nullptr;
  }
  for (std::size_t t = 0; t < 2; ++t) {
    if (impl_->trajectory_slices[t]) impl_->trajectory_renderers[t]->RemoveViewProp(impl_->trajectory_slices[t]);
    impl_->trajectory_slices[t] = nullptr;
  }
  impl_->image = nullptr;
  impl_->bounds.setEmpty();
  impl_->screws.clear();
  impl_->markers.clear();
  for (std::size_t v = 0; v < 3; ++v) impl_->place(v);
  clearTrajectory();
}

bool SliceViews::hasVolume() const {
  return impl_->image != nullptr;
}

void SliceViews::setCursor(const Eigen::Vector3d& p_lps) {
  if (!p_lps.allFinite()) throw InvalidArgumentError("slice cursor is not finite (NaN or inf)");
  impl_->cursor = p_lps;
  for (std::size_t v = 0; v < 3; ++v) impl_->place(v);
}

Eigen::Vector3d SliceViews::cursor() const {
  return impl_->cursor;
}

void SliceViews::setWindowLevel(double window, double level) {
  if (!std::isfinite(window) || !std::isfinite(level) || !(window > 0.0)) {
    throw InvalidArgumentError("window/level " + std::to_string(window) + "/" + std::to_string(level) +
                               ": the window must be a finite width > 0 (HU) and the level finite");
  }
  impl_->window = window;
  impl_->level = level;
  impl_->property->SetColorWindow(window);
  impl_->property->SetColorLevel(level);
}

Eigen::Vector2d SliceViews::windowLevel() const {
  return {impl_->window, impl_->level};
}

void SliceViews::setTool(const Eigen::Vector3d& tip_lps, const Eigen::Vector3d& axis_lps, double length_mm,
                         bool follow) {
  if (!tip_lps.allFinite() || !axis_lps.allFinite() || !std::isfinite(length_mm) || length_mm < 0.0 ||
      axis_lps.norm() < 1e-9) {
    throw InvalidArgumentError(
        "slice tool overlay: tip and axis must be finite, the axis non-zero, the length >= 0 mm");
  }
  impl_->has_tool = true;
  impl_->tool_tip = tip_lps;
  impl_->tool_end = tip_lps + length_mm * axis_lps.normalized();
  if (follow) {
    setCursor(tip_lps);
  } else {
    for (std::size_t v = 0; v < 3; ++v) impl_->updateOverlays(v);
  }
}

void SliceViews::clearTool() {
  impl_->has_tool = false;
  for (std::size_t v = 0; v < 3; ++v) impl_->updateOverlays(v);
}

void SliceViews::setUltrasoundFrame(const ImageVolume& frame_2d, const Eigen::Isometry3d& ct_T_image) {
  detail::checkImage(frame_2d, "ultrasound frame '" + frame_2d.name + "'");
  if (!ct_T_image.matrix().allFinite()) throw InvalidArgumentError("placement of the ultrasound frame is not finite");
  const Eigen::Matrix4d ct_T_pixel = ct_T_image.matrix() * frame_2d.ijkToLps();
  const double w = frame_2d.size[0] - 0.5;
  const double h = frame_2d.size[1] - 0.5;
  const Eigen::Vector2d corners[4] = {{-0.5, -0.5}, {w, -0.5}, {w, h}, {-0.5, h}};
  for (std::size_t c = 0; c < 4; ++c) {
    impl_->us_corners[c] = (ct_T_pixel * Eigen::Vector4d(corners[c].x(), corners[c].y(), 0.0, 1.0)).head<3>();
  }
  impl_->has_us = true;
  for (std::size_t v = 0; v < 3; ++v) impl_->updateOverlays(v);
}

void SliceViews::clearUltrasoundFrame() {
  impl_->has_us = false;
  for (std::size_t v = 0; v < 3; ++v) impl_->updateOverlays(v);
}

bool SliceViews::ultrasoundIntersection(SliceOrientation view, Eigen::Vector3d& a, Eigen::Vector3d& b) const {
  return impl_->intersect(static_cast<std::size_t>(view), a, b);
}

vtkRenderer* SliceViews::renderer(SliceOrientation view) const {
  return impl_->renderers[static_cast<std::size_t>(view)];
}

std::array<vtkRenderer*, 3> SliceViews::renderers() const {
  return {impl_->renderers[0], impl_->renderers[1], impl_->renderers[2]};
}

void SliceViews::resetCameras() {
  const Eigen::Vector3d extent = impl_->bounds.isEmpty() ? Eigen::Vector3d(100, 100, 100) : impl_->bounds.sizes();
  for (std::size_t v = 0; v < 3; ++v) {
    const ViewAxes ax = axesOf(static_cast<SliceOrientation>(v));
    // Half the extent along the screen's vertical, with a margin.
    const double half_height = 0.5 * std::abs(extent.dot(ax.up.cwiseAbs()));
    impl_->renderers[v]->GetActiveCamera()->SetParallelScale(1.05 * std::max(half_height, 1.0));
    impl_->place(v);
  }
}

Eigen::Vector3d sliceNormal(SliceOrientation view) {
  return axesOf(view).normal;
}

std::vector<WindowLevelPreset> ctWindowLevelPresets() {
  return {{"bone", 1000.0, 400.0}, {"soft tissue", 400.0, 40.0}, {"lung", 1400.0, -500.0}, {"brain", 100.0, 50.0}};
}

void SliceViews::scroll(SliceOrientation view, int steps) {
  const auto v = static_cast<std::size_t>(view);
  const Eigen::Vector3d n = axesOf(view).normal;
  Eigen::Vector3d p = impl_->cursor + static_cast<double>(steps) * impl_->stepAlong(v) * n;
  if (!impl_->bounds.isEmpty()) p = p.cwiseMax(impl_->bounds.min()).cwiseMin(impl_->bounds.max());
  setCursor(p);
}

void SliceViews::setCrosshairVisible(bool visible) {
  impl_->crosshair = visible;
  for (std::size_t v = 0; v < 3; ++v) impl_->updateCrosshair(v);
}

bool SliceViews::crosshairVisible() const {
  return impl_->crosshair;
}

std::optional<Eigen::Vector3d> SliceViews::pointAt(SliceOrientation view, double x, double y) const {
  vtkRenderer* r = impl_->renderers[static_cast<std::size_t>(view)];
  if (r->GetRenderWindow() == nullptr || r->GetRenderWindow()->GetSize()[0] <= 0) return std::nullopt;
  r->SetDisplayPoint(x, y, 0.0);
  r->DisplayToWorld();
  double w[4];
  r->GetWorldPoint(w);
  if (w[3] == 0.0) return std::nullopt;
  const Eigen::Vector3d p(w[0] / w[3], w[1] / w[3], w[2] / w[3]);
  // A parallel projection: the pixel's ray runs along the normal, so its point on the plane is the projection.
  const Eigen::Vector3d n = axesOf(view).normal;
  return p - (p - impl_->cursor).dot(n) * n;
}

std::optional<Eigen::Vector2d> SliceViews::displayPoint(SliceOrientation view, const Eigen::Vector3d& p_lps) const {
  vtkRenderer* r = impl_->renderers[static_cast<std::size_t>(view)];
  if (r->GetRenderWindow() == nullptr || r->GetRenderWindow()->GetSize()[0] <= 0) return std::nullopt;
  r->SetWorldPoint(p_lps.x(), p_lps.y(), p_lps.z(), 1.0);
  r->WorldToDisplay();
  double d[3];
  r->GetDisplayPoint(d);
  return Eigen::Vector2d(d[0], d[1]);
}

void SliceViews::setScrews(const std::vector<SliceScrew>& screws) {
  for (const auto& s : screws) {
    if (!s.entry.allFinite() || !s.tip.allFinite() || !(s.diameter_mm > 0.0)) {
      throw InvalidArgumentError("slice screw '" + s.name + "': entry and tip must be finite, the diameter > 0");
    }
  }
  impl_->screws = screws;
  for (std::size_t v = 0; v < 3; ++v) impl_->updateScrews(v);
}

const std::vector<SliceScrew>& SliceViews::screws() const {
  return impl_->screws;
}

std::optional<ScrewHandle> SliceViews::handleAt(SliceOrientation view, double x, double y,
                                                double tolerance_px) const {
  std::optional<ScrewHandle> best;
  for (std::size_t i = 0; i < impl_->screws.size(); ++i) {
    for (const ScrewEnd end : {ScrewEnd::Entry, ScrewEnd::Tip}) {
      const auto& s = impl_->screws[i];
      const auto d = displayPoint(view, end == ScrewEnd::Entry ? s.entry : s.tip);
      if (!d) return std::nullopt;
      const double distance = (*d - Eigen::Vector2d(x, y)).norm();
      if (distance <= tolerance_px && (!best || distance < best->distance_px)) best = ScrewHandle{i, end, distance};
    }
  }
  return best;
}

void SliceViews::setMarkers(const std::vector<SliceMarker>& markers) {
  impl_->markers = markers;
  for (std::size_t v = 0; v < 3; ++v) impl_->updateMarkers(v);
}

void SliceViews::setTrajectory(const Eigen::Vector3d& entry, const Eigen::Vector3d& tip, double diameter_mm,
                               double depth_mm) {
  if (!entry.allFinite() || !tip.allFinite() || (tip - entry).norm() < 1e-6 || !(diameter_mm > 0.0) ||
      !std::isfinite(depth_mm)) {
    throw InvalidArgumentError("trajectory view: the screw needs two distinct finite ends, a diameter > 0 and a finite "
                               "depth");
  }
  const double length = (tip - entry).norm();
  const Eigen::Vector3d a = (tip - entry) / length;
  const double r = 0.5 * diameter_mm;
  // Inline: the plane holding the axis and, as near as it can, the patient's superior axis; entry at the top.
  Eigen::Vector3d n = a.cross(Eigen::Vector3d::UnitZ());
  if (n.norm() < 0.1) n = a.cross(Eigen::Vector3d::UnitY());
  n.normalize();
  {
    vtkCamera* camera = impl_->trajectory_renderers[0]->GetActiveCamera();
    const Eigen::Vector3d focal = entry + 0.5 * length * a;
    const Eigen::Vector3d eye = focal - kCameraDistance_mm * n;
    const Eigen::Vector3d up = -a;
    camera->SetFocalPoint(focal.data());
    camera->SetPosition(eye.data());
    camera->SetViewUp(up.data());
    camera->SetParallelScale(0.5 * length + 20.0);
    impl_->trajectory_renderers[0]->ResetCameraClippingRange();
    LineLayer& layer = *impl_->trajectory_layers[0];
    layer.clear();
    const Eigen::Vector3d lift = -kOverlayLift_mm * n;
    const Eigen::Vector3d w = n.cross(a).normalized();
    const Eigen::Vector3d yellow(1.0, 0.85, 0.2);
    layer.polyline({entry + r * w + lift, tip + r * w + lift, tip - r * w + lift, entry - r * w + lift}, yellow, true);
    const Eigen::Vector3d at = entry + std::clamp(depth_mm, 0.0, length) * a + lift;
    layer.line(at - (r + 4.0) * w, at + (r + 4.0) * w, Eigen::Vector3d(0.3, 0.8, 1.0));
    layer.commit();
  }
  // Probe's eye: across the axis at the depth, seen from the entry, superior up.
  {
    vtkCamera* camera = impl_->trajectory_renderers[1]->GetActiveCamera();
    const Eigen::Vector3d focal = entry + depth_mm * a;
    const Eigen::Vector3d eye = focal - kCameraDistance_mm * a;
    Eigen::Vector3d up = Eigen::Vector3d::UnitZ() - Eigen::Vector3d::UnitZ().dot(a) * a;
    if (up.norm() < 0.1) up = -Eigen::Vector3d::UnitY() - (-Eigen::Vector3d::UnitY()).dot(a) * a;
    up.normalize();
    camera->SetFocalPoint(focal.data());
    camera->SetPosition(eye.data());
    camera->SetViewUp(up.data());
    camera->SetParallelScale(25.0);
    impl_->trajectory_renderers[1]->ResetCameraClippingRange();
    LineLayer& layer = *impl_->trajectory_layers[1];
    layer.clear();
    const Eigen::Vector3d lift = -kOverlayLift_mm * a;
    layer.circle(focal + lift, up, up.cross(a), r, Eigen::Vector3d(1.0, 0.85, 0.2));
    layer.commit();
  }
  impl_->has_trajectory = true;
}

void SliceViews::clearTrajectory() {
  impl_->has_trajectory = false;
  for (auto& layer : impl_->trajectory_layers) {
    layer->clear();
    layer->commit();
  }
}

bool SliceViews::hasTrajectory() const {
  return impl_->has_trajectory;
}

vtkRenderer* SliceViews::trajectoryRenderer(TrajectoryView view) const {
  return impl_->trajectory_renderers[static_cast<std::size_t>(view)];
}

void snapshotTrajectoryPng(SliceViews& views, const std::filesystem::path& png, int width, int height) {
  if (!views.hasTrajectory()) throw InvalidArgumentError("trajectory snapshot: no trajectory is set");
  detail::renderToPng({{views.trajectoryRenderer(TrajectoryView::Inline), {0.0, 0.0, 0.5, 1.0}},
                       {views.trajectoryRenderer(TrajectoryView::ProbeEye), {0.5, 0.0, 1.0, 1.0}}},
                      png, width, height);
}

void snapshotSlicesPng(SliceViews& views, const std::filesystem::path& png, int width, int height) {
  const auto r = views.renderers();
  detail::renderToPng({{r[0], {0.0, 0.0, 1.0 / 3.0, 1.0}},
                       {r[1], {1.0 / 3.0, 0.0, 2.0 / 3.0, 1.0}},
                       {r[2], {2.0 / 3.0, 0.0, 1.0, 1.0}}},
                      png, width, height);
}

}  // namespace mrsns::rendering
