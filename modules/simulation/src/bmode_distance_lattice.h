#pragma once
// A scene's signed distance (bone, vessel) sampled on a lattice of the image
// plane, evaluated only where its zero set may pass. The scene's distance
// functions cost about a microsecond a call, far too much per pixel (300 k
// pixels at 30 frames/s), while the surfaces cross a frame along a few lines:
// a coarse lattice is evaluated everywhere and a cell is subdivided (down to
// the fine step) only when the surface may cross it. Pixels then read the
// lattice by bilinear interpolation.
#include <Eigen/Geometry>
#include <functional>
#include <vector>

namespace mrsns::simulation::detail {

class DistanceLattice {
 public:
  /// Fine lattice step (mm). Bilinear interpolation of a signed distance
  /// misplaces a surface of curvature radius R by at most ~step^2 / (4 R):
  /// 0.08 mm for a 3 mm vessel at 1 mm, below the PSF.
  static constexpr double kFineStepMm = 1.0;
  /// Coarse cells span this many fine cells (a power of two).
  static constexpr int kCoarseCells = 8;

  /// Samples `distance` (scene frame) over the image rectangle [0, width_mm] x
  /// [0, height_mm] of the plane scene_T_image. `blur_mm`: distances below it
  /// matter to the renderer (the lumen edge's blur), so cells where the
  /// distance may drop below it are refined too. Assumes the function is
  /// 1-Lipschitz (an exact signed distance, or min/max of such), which is
  /// what bounds where the surface can be from a value at a corner.
  DistanceLattice(const std::function<double(const Eigen::Vector3d&)>& distance, const Eigen::Isometry3d& scene_T_image,
                  double width_mm, double height_mm, double blur_mm);

  [[nodiscard]] int columns() const { return nx_; }  ///< lattice nodes along x
  [[nodiscard]] int rows() const { return ny_; }     ///< lattice nodes along y (depth)
  [[nodiscard]] int evaluations() const { return evaluations_; }
  /// The lattice column i (all depths, contiguous): values[i * rows() + j].
  [[nodiscard]] const float* column(int i) const { return values_.data() + static_cast<std::size_t>(i) * ny_; }
  /// Bilinear value at image (x_mm, y_mm), clamped to the lattice.
  [[nodiscard]] double at(double x_mm, double y_mm) const;

 private:
  enum : unsigned char { kUnknown = 0, kFilled = 1, kEvaluated = 2 };
  [[nodiscard]] std::size_t index(int i, int j) const { return static_cast<std::size_t>(i) * ny_ + j; }
  void evaluate(int i, int j);
  void refine(int i0, int j0, int cells);
  void fill(int i0, int j0, int cells);

  const std::function<double(const Eigen::Vector3d&)>& distance_;
  Eigen::Isometry3d scene_T_image_;
  double blur_mm_;
  int nx_ = 0, ny_ = 0;
  int evaluations_ = 0;
  std::vector<float> values_;
  std::vector<unsigned char> state_;
};

}  // namespace mrsns::simulation::detail
