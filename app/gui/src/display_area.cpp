#include "display_area.h"

#include <QVTKOpenGLNativeWidget.h>
#include <vtkCallbackCommand.h>
#include <vtkGenericOpenGLRenderWindow.h>
#include <vtkInteractorStyleImage.h>
#include <vtkInteractorStyleTrackballCamera.h>
#include <vtkNew.h>
#include <vtkRenderWindowInteractor.h>
#include <vtkRenderer.h>
#include <vtkSmartPointer.h>

#include <QGuiApplication>
#include <QLabel>
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
  QWidget* slice_column = nullptr;
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
    }
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
  for (auto* widget : impl_->slice_widgets) {
    if (widget->isVisible()) widget->renderWindow()->Render();
  }
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

void DisplayArea::setSliceViewsVisible(bool visible) {
  impl_->slice_column->setVisible(visible);
}
bool DisplayArea::sliceViewsVisible() const {
  return impl_->slice_column->isVisible();
}

}  // namespace mrsns::gui
