#pragma once
// The digitised checkerboard of paper 000 (§2.3): a calibrated pointer
// touches every inner corner of a checkerboard fixed to a tracked board; the
// noisy corners, expressed in the board-marker frame, are fitted to the ideal
// grid (rows and columns parallel, perpendicular, evenly spaced) by RANSAC,
// which gives board_T_grid (T_p^b in the paper: pattern -> board).
//
// Grid frame ("pattern", p): origin at inner corner (row 0, col 0), x along
// the rows (increasing column), y along the columns (increasing row), z the
// board normal (x cross y, towards the camera side for OpenCV's corner order).
// Corners are numbered row-major: index = row * cols + col, the order of
// cv::findChessboardCorners for a board of `cols` x `rows` inner corners.
#include <Eigen/Geometry>
#include <span>
#include <vector>

namespace mrsns::hmd {

/// A checkerboard of rows x cols inner corners and square edge square_mm.
struct CheckerboardSpec {
  int rows = 3;
  int cols = 5;
  double square_mm = 30.0;
};

/// Inner corners in the grid frame, row-major (z = 0). Throws InvalidArgumentError for < 2 rows
/// or columns or a non-positive square.
std::vector<Eigen::Vector3d> idealGridCorners(const CheckerboardSpec& spec);

struct PointerCalibrationOptions {
  /// Pivot residual RMS above this means the tip slipped or the pointer's marker body is not
  /// rigid (a loose marker sphere, a bent shaft): refused.
  double max_rms_mm = 1.0;
  int min_poses = 10;
};

/// Tip offset of the pointer in its marker frame from pivot poses (registration::calibratePivot).
/// Throws InvalidArgumentError for non-rigid pose matrices, ComputationError for degenerate
/// motion or a residual above max_rms_mm (non-rigid pointer data).
Eigen::Vector3d calibratePointerTip(std::span<const Eigen::Isometry3d> tracker_T_pointer,
                                    const PointerCalibrationOptions& options = {}, double* rms_mm = nullptr);

/// Digitised corners in the board frame: board_T_tracker_i * tracker_T_pointer_i * tip. Throws
/// InvalidArgumentError on size mismatch or a pose that is not rigid (naming the index).
std::vector<Eigen::Vector3d> digitiseInBoard(std::span<const Eigen::Isometry3d> tracker_T_pointer,
                                             std::span<const Eigen::Isometry3d> tracker_T_board,
                                             const Eigen::Vector3d& pointer_tip);

struct GridFitOptions {
  /// A corner is an inlier when within this distance of the fitted ideal grid (~3x the
  /// digitisation noise, 3D RMS).
  double inlier_threshold_mm = 1.5;
  int ransac_iterations = 200;
  unsigned seed = 1;
  /// Fewer inliers than this fraction of the corners: refused.
  double min_inlier_fraction = 0.6;
};

struct GridFitResult {
  Eigen::Isometry3d board_T_grid = Eigen::Isometry3d::Identity();  // T_p^b
  double rms_mm = 0;                                               // over inliers
  std::vector<double> residuals_mm;                                // every corner
  std::vector<bool> inliers;
  int inlier_count = 0;
  /// Straightness and angles of the digitised lines (inliers, each line fitted alone):
  /// RMS distance of corners from their row/column line, and the mean angle between row and
  /// column directions (90 for a good digitisation).
  double line_rms_mm = 0;
  double row_column_angle_deg = 0;
  /// Mean spacing of neighbouring digitised corners along rows and columns, mm.
  double mean_spacing_mm = 0;
};

/// Fits the ideal grid to digitised corners (row-major, board frame, mm). RANSAC over minimal
/// triples of corners (a rigid fit of the ideal grid enforces parallel, perpendicular and
/// evenly spaced lines), then a least-squares refit on the inliers. Throws
/// InvalidArgumentError when the count does not match the spec or a point is not finite,
/// ComputationError when too few corners fit (wrong square size, wrong order, a moved board).
GridFitResult fitCheckerboardGrid(std::span<const Eigen::Vector3d> board_points, const CheckerboardSpec& spec,
                                  const GridFitOptions& options = {});

}  // namespace mrsns::hmd
