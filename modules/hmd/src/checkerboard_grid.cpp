// Pointer tip, digitisation and the RANSAC fit of the ideal checkerboard grid.
#include "mrsns/hmd/checkerboard_grid.h"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <random>
#include <string>

#include "mrsns/core/error.h"
#include "mrsns/core/format.h"
#include "mrsns/core/rigid.h"
#include "mrsns/registration/paired_point.h"
#include "mrsns/registration/pivot_calibration.h"

namespace mrsns::hmd {
namespace {

constexpr double kRadToDeg = 180.0 / 3.14159265358979323846;

// Rigid fit of the ideal grid (moving) onto the digitised points (fixed) for the given indices.
Eigen::Isometry3d fitSubset(const std::vector<Eigen::Vector3d>& grid, std::span<const Eigen::Vector3d> points,
                            const std::vector<int>& indices) {
  std::vector<Eigen::Vector3d> moving, fixed;
  for (int i : indices) {
    moving.push_back(grid[static_cast<size_t>(i)]);
    fixed.push_back(points[static_cast<size_t>(i)]);
  }
  registration::PairedPointOptions options;
  options.leave_one_out = false;
  const auto result = registration::registerPairedPoints(moving, fixed, options);
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = result.rotation;
  T.translation() = result.translation;
  return T;
}

// Principal direction of points and the RMS distance of the points from that line.
Eigen::Vector3d lineDirection(const std::vector<Eigen::Vector3d>& pts, double& sum_sq, int& count) {
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (const auto& p : pts) mean += p / static_cast<double>(pts.size());
  Eigen::Matrix3d scatter = Eigen::Matrix3d::Zero();
  for (const auto& p : pts) scatter += (p - mean) * (p - mean).transpose();
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(scatter);
  const Eigen::Vector3d dir = eig.eigenvectors().col(2);
  for (const auto& p : pts) {
    const Eigen::Vector3d d = p - mean;
    sum_sq += (d - d.dot(dir) * dir).squaredNorm();
    ++count;
  }
  return (pts.back() - pts.front()).dot(dir) < 0 ? Eigen::Vector3d(-dir) : dir;
}

void lineFigures(std::span<const Eigen::Vector3d> points, const std::vector<bool>& inliers,
                 const CheckerboardSpec& spec, GridFitResult& result) {
  double sum_sq = 0.0, spacing = 0.0, angle = 0.0;
  int count = 0, spacing_count = 0, angle_count = 0;
  std::vector<Eigen::Vector3d> row_dirs, col_dirs;
  auto collect = [&](bool rows) {
    const int lines = rows ? spec.rows : spec.cols, along = rows ? spec.cols : spec.rows;
    for (int l = 0; l < lines; ++l) {
      std::vector<Eigen::Vector3d> pts;
      for (int k = 0; k < along; ++k) {
        const int idx = rows ? l * spec.cols + k : k * spec.cols + l;
        if (inliers[static_cast<size_t>(idx)]) pts.push_back(points[static_cast<size_t>(idx)]);
      }
      if (pts.size() < 2) continue;
      for (size_t k = 1; k < pts.size(); ++k) {
        spacing += (pts[k] - pts[k - 1]).norm();
        ++spacing_count;
      }
      (rows ? row_dirs : col_dirs).push_back(lineDirection(pts, sum_sq, count));
    }
  };
  collect(true);
  collect(false);
  for (const auto& r : row_dirs) {
    for (const auto& c : col_dirs) {
      angle += std::acos(std::clamp(r.dot(c), -1.0, 1.0)) * kRadToDeg;
      ++angle_count;
    }
  }
  result.line_rms_mm = count > 0 ? std::sqrt(sum_sq / count) : 0.0;
  result.row_column_angle_deg = angle_count > 0 ? angle / angle_count : 0.0;
  result.mean_spacing_mm = spacing_count > 0 ? spacing / spacing_count : 0.0;
}

}  // namespace

std::vector<Eigen::Vector3d> idealGridCorners(const CheckerboardSpec& spec) {
  if (spec.rows < 2 || spec.cols < 2 || !(spec.square_mm > 0.0)) {
    throw InvalidArgumentError("checkerboard of " + std::to_string(spec.rows) + " x " + std::to_string(spec.cols) +
                               " inner corners and square " + formatGeneral(spec.square_mm) +
                               " mm: give at least 2 x 2 inner corners and a positive square size");
  }
  std::vector<Eigen::Vector3d> corners;
  for (int r = 0; r < spec.rows; ++r) {
    for (int c = 0; c < spec.cols; ++c) corners.emplace_back(c * spec.square_mm, r * spec.square_mm, 0.0);
  }
  return corners;
}

Eigen::Vector3d calibratePointerTip(std::span<const Eigen::Isometry3d> tracker_T_pointer,
                                    const PointerCalibrationOptions& options, double* rms_mm) {
  for (size_t i = 0; i < tracker_T_pointer.size(); ++i) {
    if (!isRigid(tracker_T_pointer[i].matrix(), 1e-3)) {
      throw InvalidArgumentError("pointer pivot pose " + std::to_string(i) +
                                 " is not a rigid transform: check the pose file (16 values of a 4x4 rigid matrix)");
    }
  }
  registration::PivotOptions pivot_options;
  pivot_options.min_poses = options.min_poses;
  const auto pivot = registration::calibratePivot(tracker_T_pointer, pivot_options);
  if (pivot.rms_mm > options.max_rms_mm) {
    throw ComputationError("pointer pivot calibration residual " + formatFixed(pivot.rms_mm, 2) + " mm exceeds " +
                           formatFixed(options.max_rms_mm, 2) +
                           " mm: the pointer data are not rigid (tip slipped in the divot, loose marker sphere or "
                           "bent shaft); re-seat the tip and record the pivot again");
  }
  if (rms_mm != nullptr) *rms_mm = pivot.rms_mm;
  return pivot.tip_marker;
}

std::vector<Eigen::Vector3d> digitiseInBoard(std::span<const Eigen::Isometry3d> tracker_T_pointer,
                                             std::span<const Eigen::Isometry3d> tracker_T_board,
                                             const Eigen::Vector3d& pointer_tip) {
  if (tracker_T_pointer.size() != tracker_T_board.size()) {
    throw InvalidArgumentError("digitisation has " + std::to_string(tracker_T_pointer.size()) + " pointer poses but " +
                               std::to_string(tracker_T_board.size()) + " board poses: give one pair per corner");
  }
  std::vector<Eigen::Vector3d> points;
  for (size_t i = 0; i < tracker_T_pointer.size(); ++i) {
    if (!isRigid(tracker_T_pointer[i].matrix(), 1e-3) || !isRigid(tracker_T_board[i].matrix(), 1e-3)) {
      throw InvalidArgumentError("digitisation pose " + std::to_string(i) +
                                 " (pointer or board) is not a rigid transform: check the pose files");
    }
    points.push_back(tracker_T_board[i].inverse() * (tracker_T_pointer[i] * pointer_tip));
  }
  return points;
}

GridFitResult fitCheckerboardGrid(std::span<const Eigen::Vector3d> board_points, const CheckerboardSpec& spec,
                                  const GridFitOptions& options) {
  const std::vector<Eigen::Vector3d> grid = idealGridCorners(spec);
  if (board_points.size() != grid.size()) {
    throw InvalidArgumentError("digitised corners: " + std::to_string(board_points.size()) + " points for a " +
                               std::to_string(spec.rows) + " x " + std::to_string(spec.cols) +
                               " checkerboard; digitise every inner corner, row by row");
  }
  for (size_t i = 0; i < board_points.size(); ++i) {
    if (!board_points[i].allFinite()) {
      throw InvalidArgumentError("digitised corner " + std::to_string(i) + " is not finite");
    }
  }
  const int n = static_cast<int>(grid.size());
  auto score = [&](const Eigen::Isometry3d& T, std::vector<bool>& inl, std::vector<double>& res) {
    int count = 0;
    inl.assign(grid.size(), false);
    res.assign(grid.size(), 0.0);
    for (int i = 0; i < n; ++i) {
      res[static_cast<size_t>(i)] = (T * grid[static_cast<size_t>(i)] - board_points[static_cast<size_t>(i)]).norm();
      if (res[static_cast<size_t>(i)] <= options.inlier_threshold_mm) {
        inl[static_cast<size_t>(i)] = true;
        ++count;
      }
    }
    return count;
  };
  std::mt19937 rng(options.seed);
  std::uniform_int_distribution<int> pick(0, n - 1);
  int best_count = -1;
  std::vector<bool> best_inliers;
  std::vector<bool> inl;
  std::vector<double> res;
  for (int it = 0; it < options.ransac_iterations; ++it) {
    std::vector<int> sample{pick(rng), pick(rng), pick(rng)};
    const Eigen::Vector3d a = grid[static_cast<size_t>(sample[0])], b = grid[static_cast<size_t>(sample[1])],
                          c = grid[static_cast<size_t>(sample[2])];
    if ((b - a).cross(c - a).norm() < 1e-6 * spec.square_mm * spec.square_mm) continue;  // collinear triple
    const int count = score(fitSubset(grid, board_points, sample), inl, res);
    if (count > best_count) {
      best_count = count;
      best_inliers = inl;
    }
  }
  const int needed = static_cast<int>(std::ceil(options.min_inlier_fraction * n));
  if (best_count < std::max(needed, 3)) {
    throw ComputationError(
        "checkerboard grid fit: only " + std::to_string(std::max(best_count, 0)) + " of " + std::to_string(n) +
        " digitised corners lie within " + formatFixed(options.inlier_threshold_mm, 1) + " mm of an ideal " +
        std::to_string(spec.rows) + " x " + std::to_string(spec.cols) + " grid of " + formatGeneral(spec.square_mm) +
        " mm squares: check the square size, the row-major corner order and that the board did "
        "not move");
  }
  // Refit on the inliers until the set stops changing (usually once).
  GridFitResult result;
  std::vector<bool> current = best_inliers;
  for (int round = 0; round < 5; ++round) {
    std::vector<int> idx;
    for (int i = 0; i < n; ++i) {
      if (current[static_cast<size_t>(i)]) idx.push_back(i);
    }
    result.board_T_grid = fitSubset(grid, board_points, idx);
    score(result.board_T_grid, inl, res);
    if (inl == current || std::count(inl.begin(), inl.end(), true) < 3) break;
    current = inl;
  }
  result.residuals_mm = res;
  result.inliers = current;
  double sum_sq = 0.0;
  for (int i = 0; i < n; ++i) {
    if (current[static_cast<size_t>(i)]) {
      sum_sq += res[static_cast<size_t>(i)] * res[static_cast<size_t>(i)];
      ++result.inlier_count;
    }
  }
  result.rms_mm = std::sqrt(sum_sq / std::max(result.inlier_count, 1));
  lineFigures(board_points, current, spec, result);
  return result;
}

}  // namespace mrsns::hmd
