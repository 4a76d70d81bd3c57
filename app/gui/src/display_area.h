#pragma once
// The display area of paper 001 Fig. 4: the 3D navigation scene
// (rendering::Scene) in a VTK OpenGL widget beside the axial, sagittal and
// coronal CT slice views (rendering::SliceViews). The only place that
// includes Qt's VTK widgets, so the rest of the GUI compiles without them.
#include <Eigen/Core>
#include <QWidget>
#include <array>
#include <memory>
#include <optional>

class QLabel;
class QSplitter;

namespace mrsns::rendering {
class Scene;
class SliceViews;
}  // namespace mrsns::rendering

namespace mrsns::gui {

/// Call before the QApplication exists: VTK's Qt widget needs an OpenGL
/// 3.2 core surface format as the application default.
void prepareOpenGlSurfaceFormat();

/// False on Qt platforms without OpenGL windows (offscreen, minimal): the
/// display area then shows placeholders and the rest of the window works.
bool openGlViewsAvailable();

class DisplayArea : public QWidget {
  Q_OBJECT
 public:
  explicit DisplayArea(QWidget* parent = nullptr);
  ~DisplayArea() override;

  rendering::Scene& scene();
  rendering::SliceViews& slices();
  [[nodiscard]] bool hasOpenGlViews() const { return gl_views_; }

  /// Re-renders the 3D view and the slice views (after the scene changed).
  void render();
  /// Re-renders the 3D view only (the live navigation view, many times a second).
  void renderScene();
  /// Back to the home view (Home key, Reset camera): the one set by
  /// setHomeView, else the scene fitted from the front.
  void resetCamera();
  struct HomeView {
    Eigen::Vector3d position, focal_point, view_up;
  };
  void setHomeView(std::optional<HomeView> view);
  void setSliceViewsVisible(bool visible);
  [[nodiscard]] bool sliceViewsVisible() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
  bool gl_views_ = false;
  std::optional<HomeView> home_;
};

}  // namespace mrsns::gui
