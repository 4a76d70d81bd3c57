#include "bmode_distance_lattice.h"

#include <algorithm>
#include <cmath>

namespace mrsns::simulation::detail {

namespace {

// Lattice cells covering `extent_mm`, rounded up to whole coarse cells.
int cellsFor(double extent_mm) {
  const int fine = std::max(1, static_cast<int>(std::ceil(extent_mm / DistanceLattice::kFineStepMm - 1e-9)));
  const int coarse = (fine + DistanceLattice::kCoarseCells - 1) / DistanceLattice::kCoarseCells;
  return coarse * DistanceLattice::kCoarseCells;
}

}  // namespace

DistanceLattice::DistanceLattice(const std::function<double(const Eigen::Vector3d&)>& distance,
                                 const Eigen::Isometry3d& scene_T_image, double width_mm, double height_mm,
                                 double blur_mm)
    : distance_(distance), scene_T_image_(scene_T_image), blur_mm_(blur_mm) {
  const int cells_x = cellsFor(width_mm), cells_y = cellsFor(height_mm);
  nx_ = cells_x + 1;
  ny_ = cells_y + 1;
  values_.assign(static_cast<std::size_t>(nx_) * ny_, 0.0f);
  state_.assign(values_.size(), kUnknown);
  for (int i = 0; i < nx_; i += kCoarseCells) {
    for (int j = 0; j < ny_; j += kCoarseCells) evaluate(i, j);
  }
  for (int i = 0; i < cells_x; i += kCoarseCells) {
    for (int j = 0; j < cells_y; j += kCoarseCells) refine(i, j, kCoarseCells);
  }
}

double DistanceLattice::at(double x_mm, double y_mm) const {
  const double u = std::clamp(x_mm / kFineStepMm, 0.0, nx_ - 1.0), v = std::clamp(y_mm / kFineStepMm, 0.0, ny_ - 1.0);
  const int i = std::min(static_cast<int>(u), nx_ - 2), j = std::min(static_cast<int>(v), ny_ - 2);
  const double fx = u - i, fy = v - j;
  const double d0 = values_[index(i, j)] + fy * (values_[index(i, j + 1)] - values_[index(i, j)]);
  const double d1 = values_[index(i + 1, j)] + fy * (values_[index(i + 1, j + 1)] - values_[index(i + 1, j)]);
  return d0 + fx * (d1 - d0);
}

void DistanceLattice::evaluate(int i, int j) {
  const std::size_t k = index(i, j);
  if (state_[k] == kEvaluated) return;
  const Eigen::Vector3d point_image(i * kFineStepMm, j * kFineStepMm, 0.0);
  values_[k] = static_cast<float>(distance_(scene_T_image_ * point_image));
  state_[k] = kEvaluated;
  ++evaluations_;
}

// A point of a square cell of side s lies within s / sqrt(2) of one of its
// corners, so for a 1-Lipschitz distance |d| >= min|d(corner)| - s / sqrt(2)
// over the whole cell: when that bound exceeds the blur, neither the
// surface nor its blurred edge is inside and the corners' bilinear
// interpolation is as good as the function there.
void DistanceLattice::refine(int i0, int j0, int cells) {
  const int i1 = i0 + cells, j1 = j0 + cells;
  const double nearest = std::min({std::abs(values_[index(i0, j0)]), std::abs(values_[index(i1, j0)]),
                                   std::abs(values_[index(i0, j1)]), std::abs(values_[index(i1, j1)])});
  const double reach = cells * kFineStepMm * std::sqrt(0.5) + blur_mm_;
  if (nearest > reach) {
    fill(i0, j0, cells);
    return;
  }
  if (cells == 1) return;
  const int half = cells / 2, im = i0 + half, jm = j0 + half;
  evaluate(im, j0);
  evaluate(i0, jm);
  evaluate(im, jm);
  evaluate(i1, jm);
  evaluate(im, j1);
  refine(i0, j0, half);
  refine(im, j0, half);
  refine(i0, jm, half);
  refine(im, jm, half);
}

void DistanceLattice::fill(int i0, int j0, int cells) {
  const float d00 = values_[index(i0, j0)], d10 = values_[index(i0 + cells, j0)];
  const float d01 = values_[index(i0, j0 + cells)], d11 = values_[index(i0 + cells, j0 + cells)];
  const float inv = 1.0f / static_cast<float>(cells);
  for (int a = 0; a <= cells; ++a) {
    const float fx = static_cast<float>(a) * inv;
    for (int b = 0; b <= cells; ++b) {
      const std::size_t k = index(i0 + a, j0 + b);
      // A neighbour's refinement may have evaluated the shared edge: keep it.
      if (state_[k] == kEvaluated) continue;
      const float fy = static_cast<float>(b) * inv;
      values_[k] = (1 - fx) * ((1 - fy) * d00 + fy * d01) + fx * ((1 - fy) * d10 + fy * d11);
      state_[k] = kFilled;
    }
  }
}

}  // namespace mrsns::simulation::detail
