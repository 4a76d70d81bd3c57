// Three orthogonal reslices of a CT through a cursor, each a parallel camera
// whose focal point is the cursor: vtkImageResliceMapper cuts the volume at
// the focal plane facing the camera, so moving the cursor is a camera move.
#include "mrsns/rendering/slice_views.h"

#include <vtkActor.h>
#include <vtkCamera.h>
#include <vtkImageData.h>
#include <vtkImageProperty.h>
#include <vtkImageResliceMapper.h>
#include <vtkImageSlice.h>
#include <vtkLineSource.h>
#include <vtkMatrix4x4.h>
#include <vtkPolyDataMapper.h>
#include <vtkProperty.h>
#include <vtkRenderer.h>
#include <vtkSphereSource.h>

#include <cmath>

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
    }
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
  impl_->cursor = impl_->bounds.center();
  setWindowLevel(400.0, 40.0);
  resetCameras();
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

void snapshotSlicesPng(SliceViews& views, const std::filesystem::path& png, int width, int height) {
  const auto r = views.renderers();
  detail::renderToPng({{r[0], {0.0, 0.0, 1.0 / 3.0, 1.0}},
                       {r[1], {1.0 / 3.0, 0.0, 2.0 / 3.0, 1.0}},
                       {r[2], {2.0 / 3.0, 0.0, 1.0, 1.0}}},
                      png, width, height);
}

}  // namespace mrsns::rendering
