#pragma once
// The display area of paper 001 Fig. 4: the 3D navigation scene
// (rendering::Scene) in a VTK OpenGL widget beside the axial, sagittal and
// coronal CT slice views (rendering::SliceViews). The only place that
// includes Qt's VTK widgets, so the rest of the GUI compiles without them.
#include <Eigen/Core>
#include <QWidget>
#include <array>
#include <cstddef>
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
  /// The two views resliced along the selected screw (inline, probe's eye), below the slice views.
  void setTrajectoryVisible(bool visible);
  [[nodiscard]] bool trajectoryVisible() const;
  /// Re-renders the slice and trajectory views only (scrolling, dragging a screw's end).
  void renderSlices();

  /// In pick mode a left click on a slice or on a surface of the 3D view picks
  /// a point (slicePointPicked, surfacePointPicked) instead of moving the
  /// crosshair or turning the camera: placing a screw's ends or a fiducial.
  void setPickMode(bool on);
  [[nodiscard]] bool pickMode() const { return pick_mode_; }

  /// What a mouse on a slice view does, callable from tests with VTK display
  /// coordinates of that view (origin at the bottom left): a left click (or a
  /// drag off any screw end) moves the crosshair there, a drag from a screw's
  /// end moves that end in the view's plane, the wheel scrolls the slice.
  void slicePress(int view, double x, double y);
  void sliceMove(int view, double x, double y);
  void sliceRelease(int view, double x, double y);
  void sliceWheel(int view, int steps);
  /// A left click on the 3D view at VTK display coordinates: in pick mode, the surface point there.
  void sceneClick(double x, double y);

 signals:
  /// The crosshair moved (a click, a drag or a scroll on a slice).
  void cursorMoved(const Eigen::Vector3d& p_lps);
  /// Pick mode: a point of a slice's plane, or of a model's surface in the 3D view.
  void slicePointPicked(const Eigen::Vector3d& p_lps);
  void surfacePointPicked(const Eigen::Vector3d& p_lps);
  /// A screw's end dragged on a slice (0 entry, 1 tip), continuously, then once released.
  void screwEndDragged(std::size_t screw, int end, const Eigen::Vector3d& p_lps);
  void screwEndReleased(std::size_t screw, int end, const Eigen::Vector3d& p_lps);

 protected:
  bool eventFilter(QObject* watched, QEvent* event) override;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
  bool gl_views_ = false;
  std::optional<HomeView> home_;
  bool pick_mode_ = false;
  struct Drag {
    int view = -1;
    bool on_handle = false;
    std::size_t screw = 0;
    int end = 0;
    Eigen::Vector3d original = Eigen::Vector3d::Zero();
    double x0 = 0.0, y0 = 0.0;
    bool moved = false;
  };
  std::optional<Drag> drag_;
};

}  // namespace mrsns::gui
