#pragma once
// Axial, sagittal and coronal reslices of a CT volume through a cursor point,
// with the ultrasound frame's intersection and the tool tip and axis drawn on
// each, and a window/level. One vtkRenderer per view for embedding; no Qt.
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <array>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "mrsns/core/image.h"

class vtkRenderer;

namespace mrsns::rendering {

/// LPS-aligned planes: axial (normal z, seen from the feet with the patient's
/// left on the right of the screen, anterior up), sagittal (normal x, anterior
/// left, superior up), coronal (normal y, patient's left on the right,
/// superior up): the radiological convention.
enum class SliceOrientation { Axial = 0, Sagittal = 1, Coronal = 2 };

/// The unit normal of a view's plane (its direction of projection, LPS).
[[nodiscard]] Eigen::Vector3d sliceNormal(SliceOrientation view);

/// A named window/level for CT in Hounsfield units.
struct WindowLevelPreset {
  std::string name;
  double window = 400.0;
  double level = 40.0;
};

/// 3D Slicer's CT presets: bone (1000/400), soft tissue (400/40), lung
/// (1400/-500), brain (100/50).
[[nodiscard]] std::vector<WindowLevelPreset> ctWindowLevelPresets();

/// A planned screw drawn on the slices: its outline (the screw's diameter
/// around its axis) projected on each plane, and a handle at each end.
struct SliceScrew {
  std::string name;
  Eigen::Vector3d entry = Eigen::Vector3d::Zero();  ///< LPS mm
  Eigen::Vector3d tip = Eigen::Vector3d::Zero();    ///< LPS mm, entry + length * direction
  double diameter_mm = 3.5;
  Eigen::Vector3d rgb = Eigen::Vector3d(0.2, 0.9, 0.3);
  bool selected = false;
};

enum class ScrewEnd { Entry, Tip };

/// The screw end under the pointer.
struct ScrewHandle {
  std::size_t screw = 0;  ///< index into the screws given to setScrews
  ScrewEnd end = ScrewEnd::Entry;
  double distance_px = 0.0;
};

/// A point drawn on the slices as a cross (a fiducial, a picked point).
struct SliceMarker {
  std::string label;
  Eigen::Vector3d position = Eigen::Vector3d::Zero();  ///< LPS mm
  Eigen::Vector3d rgb = Eigen::Vector3d(0.3, 0.8, 1.0);
};

/// The two views resliced along a screw: inline (a plane holding the screw's
/// axis and, as near as it can, the patient's superior axis; entry at the
/// top) and probe's eye (the plane across the axis at a depth, seen from
/// the entry).
enum class TrajectoryView { Inline = 0, ProbeEye = 1 };

class SliceViews {
 public:
  SliceViews();
  ~SliceViews();
  SliceViews(const SliceViews&) = delete;
  SliceViews& operator=(const SliceViews&) = delete;

  /// The CT (any pixel type, LPS, any direction matrix). Puts the cursor at
  /// the volume's centre and the window/level at 400/40 HU (soft tissue and
  /// bone). Throws InvalidArgumentError for an empty volume or one whose
  /// data size does not match its size and pixel type.
  void setVolume(const ImageVolume& ct);
  [[nodiscard]] bool hasVolume() const;
  /// Removes the CT (another session without one is shown).
  void clearVolume();

  /// The point (LPS mm) all three planes pass through.
  void setCursor(const Eigen::Vector3d& p_lps);
  [[nodiscard]] Eigen::Vector3d cursor() const;
  /// Moves the cursor along `view`'s normal by `steps` voxels (the CT's
  /// spacing along that normal), kept inside the volume: scrolling a view.
  void scroll(SliceOrientation view, int steps);
  /// The crosshair: each view shows where the other two planes cut it (off
  /// until set: the workstation's planning views show it, snapshots of the
  /// anatomy do not).
  void setCrosshairVisible(bool visible);
  [[nodiscard]] bool crosshairVisible() const;

  /// The point of `view`'s plane under display position (x, y) of its render
  /// window (VTK display pixels: origin at the bottom left); nullopt when the
  /// view is not in a window yet.
  [[nodiscard]] std::optional<Eigen::Vector3d> pointAt(SliceOrientation view, double x, double y) const;
  /// Where an LPS point projects in `view`'s window (display pixels), nullopt without a window.
  [[nodiscard]] std::optional<Eigen::Vector2d> displayPoint(SliceOrientation view, const Eigen::Vector3d& p_lps) const;

  /// The planned screws (replacing any given before).
  void setScrews(const std::vector<SliceScrew>& screws);
  [[nodiscard]] const std::vector<SliceScrew>& screws() const;
  /// The screw end nearest to display position (x, y) in `view` within
  /// `tolerance_px`, if any.
  [[nodiscard]] std::optional<ScrewHandle> handleAt(SliceOrientation view, double x, double y,
                                                    double tolerance_px = 8.0) const;
  /// Points drawn as crosses (replacing any given before); the ones within
  /// half a voxel of a view's plane are drawn larger.
  void setMarkers(const std::vector<SliceMarker>& markers);

  /// Reslices along the screw from `entry` to `tip` (LPS mm): the inline view
  /// centred on the screw, the probe's-eye view across it `depth_mm` from the
  /// entry. Throws InvalidArgumentError for a degenerate screw.
  void setTrajectory(const Eigen::Vector3d& entry, const Eigen::Vector3d& tip, double diameter_mm, double depth_mm);
  void clearTrajectory();
  [[nodiscard]] bool hasTrajectory() const;
  [[nodiscard]] vtkRenderer* trajectoryRenderer(TrajectoryView view) const;

  /// Grey levels: `window` wide around `level` (HU). Throws
  /// InvalidArgumentError for a window <= 0 or non-finite values.
  void setWindowLevel(double window, double level);
  [[nodiscard]] Eigen::Vector2d windowLevel() const;  ///< (window, level)

  /// The tool overlay: its tip (a dot) and its axis from the tip towards
  /// `tip + length_mm * axis` (a line), projected on each plane, LPS mm.
  /// `follow` moves the cursor to the tip.
  void setTool(const Eigen::Vector3d& tip_lps, const Eigen::Vector3d& axis_lps, double length_mm, bool follow = true);
  void clearTool();

  /// The ultrasound frame overlay: where the frame's rectangle (its pixel
  /// grid placed by ct_T_image, as Scene::setUltrasoundSlice) cuts each
  /// plane, drawn as a segment. Throws InvalidArgumentError for an empty frame.
  void setUltrasoundFrame(const ImageVolume& frame_2d, const Eigen::Isometry3d& ct_T_image);
  void clearUltrasoundFrame();

  /// The segment (LPS mm) the ultrasound frame cuts out of `view`'s plane;
  /// false when the frame does not reach the plane (or there is no frame).
  [[nodiscard]] bool ultrasoundIntersection(SliceOrientation view, Eigen::Vector3d& a, Eigen::Vector3d& b) const;

  [[nodiscard]] vtkRenderer* renderer(SliceOrientation view) const;
  [[nodiscard]] std::array<vtkRenderer*, 3> renderers() const;  ///< axial, sagittal, coronal
  /// Fits each view's camera to the volume's extent in its plane.
  void resetCameras();

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

/// Renders the three views side by side (axial, sagittal, coronal, each
/// width/3 wide) offscreen into an RGB PNG. Throws like snapshotPng.
void snapshotSlicesPng(SliceViews& views, const std::filesystem::path& png, int width, int height);

/// Renders the trajectory views side by side (inline, probe's eye) offscreen
/// into an RGB PNG. Throws like snapshotPng, and InvalidArgumentError without
/// a trajectory.
void snapshotTrajectoryPng(SliceViews& views, const std::filesystem::path& png, int width, int height);

}  // namespace mrsns::rendering
