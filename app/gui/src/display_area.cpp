#include "display_area.h"

#include <QVTKOpenGLNativeWidget.h>
#include <vtkCallbackCommand.h>
#include <vtkCellPicker.h>
#include <vtkGenericOpenGLRenderWindow.h>
#include <vtkInteractorStyleImage.h>
#include <vtkInteractorStyleTrackballCamera.h>
#include <vtkNew.h>
#include <vtkRenderWindowInteractor.h>
#include <vtkRenderer.h>
#include <vtkSmartPointer.h>

#include <cmath>

#include <QGuiApplication>
#include <QHBoxLayout>
#include <QLabel>
#include <QMouseEvent>
#include <QWheelEvent>
#include <QSplitter>
#include <QSurfaceFormat>
#include <QVBoxLayout>

#include "mrsns/rendering/scene.h"
#include "mrsns/rendering/slice_views.h"

namespace mrsns::gui {

void prepareOpenGlSurfaceFormat() {
  QSurfaceFormat format = QVTKOpenGLNativeWidget::defaultFormat();
  // Multisampling costs ~40 % of a frame on Mesa's software rasteriser.
  format.setSamples(0);
  QSurfaceFormat::setDefaultFormat(format);
}

bool openGlViewsAvailable() {
  const QString platform = QGuiApplication::platformName();
  return platform != QLatin1String("offscreen") && platform != QLatin1String("minimal") &&
         qgetenv("MRSNS_GUI_NO_GL").isEmpty();
}

struct DisplayArea::Impl {
  rendering::Scene scene;
  rendering::SliceViews slices;
  QVTKOpenGLNativeWidget* view3d = nullptr;
  std::array<QVTKOpenGLNativeWidget*, 3> slice_widgets{};
  std::array<QVTKOpenGLNativeWidget*, 2> trajectory_widgets{};
  QWidget* slice_column = nullptr;
  QWidget* trajectory_row = nullptr;
  QLabel* trajectory_title = nullptr;
  vtkNew<vtkCallbackCommand> interaction;
};

namespace {

QVTKOpenGLNativeWidget* makeVtkWidget(QWidget* parent, vtkRenderer* renderer, const QString& name) {
  auto* widget = new QVTKOpenGLNativeWidget(parent);
  widget->setObjectName(name);
  vtkNew<vtkGenericOpenGLRenderWindow> window;
  window->SetMultiSamples(0);
  window->AddRenderer(renderer);
  widget->setRenderWindow(window);
  return widget;
}

QLabel* placeholder(QWidget* parent, const QString& name, const QString& text) {
  auto* label = new QLabel(text, parent);
  label->setObjectName(name);
  label->setAlignment(Qt::AlignCenter);
  label->setWordWrap(true);
  label->setProperty("placeholder", true);
  return label;
}

}  // namespace

DisplayArea::DisplayArea(QWidget* parent) : QWidget(parent), impl_(std::make_unique<Impl>()) {
  gl_views_ = openGlViewsAvailable();
  auto* layout = new QVBoxLayout(this);
  layout->setContentsMargins(0, 0, 0, 0);
  auto* splitter = new QSplitter(Qt::Horizontal, this);
  splitter->setObjectName(QStringLiteral("displaySplitter"));
  layout->addWidget(splitter);

  impl_->slice_column = new QWidget(splitter);
  impl_->slice_column->setObjectName(QStringLiteral("sliceViews"));
  auto* column = new QVBoxLayout(impl_->slice_column);
  column->setContentsMargins(0, 0, 0, 0);
  column->setSpacing(2);
  const std::array<QString, 3> slice_names{QStringLiteral("viewAxial"), QStringLiteral("viewSagittal"),
                                           QStringLiteral("viewCoronal")};
  const std::array<QString, 3> slice_titles{tr("Axial"), tr("Sagittal"), tr("Coronal")};

  if (gl_views_) {
    impl_->view3d = makeVtkWidget(splitter, impl_->scene.renderer(), QStringLiteral("view3d"));
    // Decimated meshes while the camera moves, full detail when it rests.
    impl_->scene.setDetailMode(rendering::DetailMode::Automatic);
    impl_->interaction->SetClientData(&impl_->scene);
    impl_->interaction->SetCallback([](vtkObject*, unsigned long event, void* client, void*) {
      static_cast<rendering::Scene*>(client)->setInteracting(event == vtkCommand::StartInteractionEvent);
    });
    auto* interactor = impl_->view3d->interactor();
    vtkNew<vtkInteractorStyleTrackballCamera> style;
    interactor->SetInteractorStyle(style);
    interactor->AddObserver(vtkCommand::StartInteractionEvent, impl_->interaction);
    interactor->AddObserver(vtkCommand::EndInteractionEvent, impl_->interaction);
    impl_->slices.setCrosshairVisible(true);  // linked views: each shows where the other two cut it
    const auto renderers = impl_->slices.renderers();
    for (std::size_t i = 0; i < 3; ++i) {
      auto* widget = makeVtkWidget(impl_->slice_column, renderers[i], slice_names[i]);
      widget->setToolTip(slice_titles[i]);
      vtkNew<vtkInteractorStyleImage> image_style;
      widget->interactor()->SetInteractorStyle(image_style);
      widget->setMinimumSize(160, 120);
      auto* title = new QLabel(slice_titles[i], impl_->slice_column);
      title->setObjectName(QStringLiteral("sliceTitle"));
      column->addWidget(title);
      column->addWidget(widget, 1);
      impl_->slice_widgets[i] = widget;
      widget->installEventFilter(this);
    }
    impl_->trajectory_row = new QWidget(impl_->slice_column);
    impl_->trajectory_row->setObjectName(QStringLiteral("trajectoryViews"));
    auto* row = new QHBoxLayout(impl_->trajectory_row);
    row->setContentsMargins(0, 0, 0, 0);
    row->setSpacing(2);
    const std::array<QString, 2> names{QStringLiteral("viewTrajectoryInline"), QStringLiteral("viewTrajectoryProbe")};
    const std::array<QString, 2> tips{tr("Along the screw (entry at the top)"), tr("Across the screw (probe's eye)")};
    for (std::size_t t = 0; t < 2; ++t) {
      auto* widget = makeVtkWidget(impl_->trajectory_row,
                                   impl_->slices.trajectoryRenderer(static_cast<rendering::TrajectoryView>(t)), names[t]);
      widget->setToolTip(tips[t]);
      vtkNew<vtkInteractorStyleImage> image_style;
      widget->interactor()->SetInteractorStyle(image_style);
      widget->setMinimumSize(120, 120);
      row->addWidget(widget, 1);
      impl_->trajectory_widgets[t] = widget;
    }
    impl_->trajectory_title = new QLabel(tr("Trajectory"), impl_->slice_column);
    impl_->trajectory_title->setObjectName(QStringLiteral("sliceTitle"));
    column->addWidget(impl_->trajectory_title);
    column->addWidget(impl_->trajectory_row, 1);
    impl_->trajectory_row->hide();
    impl_->trajectory_title->hide();
    impl_->view3d->installEventFilter(this);
    splitter->insertWidget(0, impl_->view3d);
  } else {
    splitter->insertWidget(0, placeholder(splitter, QStringLiteral("view3d"),
                                          tr("3D view needs an OpenGL display (run under X11 or xvfb-run).")));
    for (std::size_t i = 0; i < 3; ++i) {
      column->addWidget(placeholder(impl_->slice_column, slice_names[i], slice_titles[i]), 1);
    }
  }
  splitter->setStretchFactor(0, 3);
  splitter->setStretchFactor(1, 1);
  splitter->setSizes({900, 300});
}

DisplayArea::~DisplayArea() = default;

rendering::Scene& DisplayArea::scene() {
  return impl_->scene;
}
rendering::SliceViews& DisplayArea::slices() {
  return impl_->slices;
}

void DisplayArea::render() {
  if (!gl_views_) return;
  impl_->view3d->renderWindow()->Render();
  renderSlices();
}

void DisplayArea::renderScene() {
  if (gl_views_) impl_->view3d->renderWindow()->Render();
}

void DisplayArea::setHomeView(std::optional<HomeView> view) {
  home_ = std::move(view);
}

void DisplayArea::resetCamera() {
  if (home_) {
    impl_->scene.setCamera(home_->position, home_->focal_point, home_->view_up);
  } else {
    impl_->scene.resetCamera();
  }
  if (impl_->slices.hasVolume()) impl_->slices.resetCameras();
  render();
}

void DisplayArea::renderSlices() {
  if (!gl_views_) return;
  for (auto* widget : impl_->slice_widgets) {
    if (widget->isVisible()) widget->renderWindow()->Render();
  }
  for (auto* widget : impl_->trajectory_widgets) {
    if (widget->isVisible()) widget->renderWindow()->Render();
  }
}

void DisplayArea::setTrajectoryVisible(bool visible) {
  if (!gl_views_) return;
  impl_->trajectory_row->setVisible(visible);
  impl_->trajectory_title->setVisible(visible);
  if (visible) renderSlices();
}

bool DisplayArea::trajectoryVisible() const {
  return gl_views_ && impl_->trajectory_row->isVisible();
}

void DisplayArea::setPickMode(bool on) {
  pick_mode_ = on;
  const Qt::CursorShape shape = on ? Qt::CrossCursor : Qt::ArrowCursor;
  if (impl_->view3d) impl_->view3d->setCursor(shape);
  for (auto* widget : impl_->slice_widgets) {
    if (widget) widget->setCursor(shape);
  }
}

void DisplayArea::slicePress(int view, double x, double y) {
  if (view < 0 || view > 2 || !impl_->slices.hasVolume()) return;
  const auto v = static_cast<rendering::SliceOrientation>(view);
  Drag d;
  d.view = view;
  d.x0 = x;
  d.y0 = y;
  if (!pick_mode_) {
    if (const auto handle = impl_->slices.handleAt(v, x, y)) {
      d.on_handle = true;
      d.screw = handle->screw;
      d.end = handle->end == rendering::ScrewEnd::Entry ? 0 : 1;
      const auto& screw = impl_->slices.screws().at(handle->screw);
      d.original = d.end == 0 ? screw.entry : screw.tip;
    }
  }
  drag_ = d;
}

void DisplayArea::sliceMove(int view, double x, double y) {
  if (!drag_ || drag_->view != view) return;
  const auto v = static_cast<rendering::SliceOrientation>(view);
  if (std::hypot(x - drag_->x0, y - drag_->y0) > 3.0) drag_->moved = true;
  if (!drag_->moved || pick_mode_) return;
  const auto p = impl_->slices.pointAt(v, x, y);
  if (!p) return;
  if (drag_->on_handle) {
    // While an end moves, the 3D view draws the decimated models, as while the camera turns: each move
    // re-renders every view, and full-detail bone at 0.7 mm takes a software renderer most of 100 ms.
    impl_->scene.setInteracting(true);
    // In the view's plane, at the end's own depth across it: a drag never moves it along the normal.
    const Eigen::Vector3d n = rendering::sliceNormal(v);
    emit screwEndDragged(drag_->screw, drag_->end,
                         *p + (drag_->original - impl_->slices.cursor()).dot(n) * n);
  } else {
    impl_->slices.setCursor(*p);
    renderSlices();
    emit cursorMoved(*p);
  }
}

void DisplayArea::sliceRelease(int view, double x, double y) {
  if (!drag_ || drag_->view != view) return;
  const Drag d = *drag_;
  drag_.reset();
  if (d.on_handle) impl_->scene.setInteracting(false);  // what renders after the release is at full detail
  const auto v = static_cast<rendering::SliceOrientation>(view);
  const auto p = impl_->slices.pointAt(v, x, y);
  if (!p) return;
  if (pick_mode_) {
    if (!d.moved) emit slicePointPicked(*p);
    return;
  }
  if (d.on_handle) {
    const Eigen::Vector3d n = rendering::sliceNormal(v);
    if (d.moved) emit screwEndReleased(d.screw, d.end, *p + (d.original - impl_->slices.cursor()).dot(n) * n);
    return;
  }
  impl_->slices.setCursor(*p);
  renderSlices();
  emit cursorMoved(*p);
}

void DisplayArea::sliceWheel(int view, int steps) {
  if (view < 0 || view > 2 || !impl_->slices.hasVolume() || steps == 0) return;
  impl_->slices.scroll(static_cast<rendering::SliceOrientation>(view), steps);
  renderSlices();
  emit cursorMoved(impl_->slices.cursor());
}

void DisplayArea::sceneClick(double x, double y) {
  if (!pick_mode_ || !gl_views_) return;
  vtkNew<vtkCellPicker> picker;
  picker->SetTolerance(0.0005);
  if (picker->Pick(x, y, 0.0, impl_->scene.renderer()) == 0) return;
  double p[3];
  picker->GetPickPosition(p);
  emit surfacePointPicked(Eigen::Vector3d(p[0], p[1], p[2]));
}

bool DisplayArea::eventFilter(QObject* watched, QEvent* event) {
  const auto type = event->type();
  if (type != QEvent::MouseButtonPress && type != QEvent::MouseMove && type != QEvent::MouseButtonRelease &&
      type != QEvent::Wheel) {
    return QWidget::eventFilter(watched, event);
  }
  auto* widget = qobject_cast<QWidget*>(watched);
  if (widget == nullptr) return false;
  const double ratio = widget->devicePixelRatioF();
  // Qt's logical pixels from the top left to VTK's display pixels from the bottom left.
  const auto toVtk = [&](const QPointF& pos) {
    return std::pair<double, double>(pos.x() * ratio, (widget->height() - pos.y() - 1.0) * ratio);
  };
  if (watched == impl_->view3d) {
    if (!pick_mode_) return false;
    if (type == QEvent::MouseButtonPress) {
      const auto* mouse = static_cast<QMouseEvent*>(event);
      if (mouse->button() != Qt::LeftButton) return false;
      const auto [x, y] = toVtk(mouse->localPos());
      sceneClick(x, y);
      return true;
    }
    return type != QEvent::Wheel && static_cast<QMouseEvent*>(event)->buttons() & Qt::LeftButton;
  }
  int view = -1;
  for (int v = 0; v < 3; ++v) {
    if (watched == impl_->slice_widgets[static_cast<std::size_t>(v)]) view = v;
  }
  if (view < 0) return false;
  if (type == QEvent::Wheel) {
    const auto* wheel = static_cast<QWheelEvent*>(event);
    if (wheel->modifiers() & Qt::ControlModifier) return false;  // VTK zooms
    const int steps = wheel->angleDelta().y() / 120 * ((wheel->modifiers() & Qt::ShiftModifier) ? 5 : 1);
    sliceWheel(view, steps);
    return true;
  }
  const auto* mouse = static_cast<QMouseEvent*>(event);
  const auto [x, y] = toVtk(mouse->localPos());
  if (type == QEvent::MouseButtonPress) {
    if (mouse->button() != Qt::LeftButton) return false;  // VTK pans and zooms with the others
    slicePress(view, x, y);
    return true;
  }
  if (type == QEvent::MouseMove) {
    if (!(mouse->buttons() & Qt::LeftButton) || !drag_) return false;
    sliceMove(view, x, y);
    return true;
  }
  if (mouse->button() != Qt::LeftButton || !drag_) return false;
  sliceRelease(view, x, y);
  return true;
}

void DisplayArea::setSliceViewsVisible(bool visible) {
  impl_->slice_column->setVisible(visible);
}
bool DisplayArea::sliceViewsVisible() const {
  return impl_->slice_column->isVisible();
}

}  // namespace mrsns::gui
