#pragma once
// Axial, sagittal and coronal reslices of a CT volume through a cursor point,
// with the ultrasound frame's intersection and the tool tip and axis drawn on
// each, and a window/level. One vtkRenderer per view for embedding; no Qt.
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <array>
#include <filesystem>
#include <memory>

#include "mrsns/core/image.h"

class vtkRenderer;

namespace mrsns::rendering {

/// LPS-aligned planes: axial (normal z, seen from the feet with the patient's
/// left on the right of the screen, anterior up), sagittal (normal x, anterior
/// left, superior up), coronal (normal y, patient's left on the right,
/// superior up): the radiological convention.
enum class SliceOrientation { Axial = 0, Sagittal = 1, Coronal = 2 };

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

  /// The point (LPS mm) all three planes pass through.
  void setCursor(const Eigen::Vector3d& p_lps);
  [[nodiscard]] Eigen::Vector3d cursor() const;

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

}  // namespace mrsns::rendering
