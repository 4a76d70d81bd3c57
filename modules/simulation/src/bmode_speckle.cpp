#include "bmode_speckle.h"

#include <Eigen/Core>
#include <algorithm>
#include <cmath>

namespace mrsns::simulation::detail {

namespace {

// Gaussian smoothing kernel of `sigma_nodes`, normalised to unit sum of
// squares so unit-variance white noise stays unit variance.
std::vector<float> unitPowerKernel(double sigma_nodes) {
  const int radius = static_cast<int>(std::ceil(2.0 * sigma_nodes));
  std::vector<float> w(static_cast<std::size_t>(2 * radius + 1));
  double power = 0.0;
  for (int k = -radius; k <= radius; ++k) {
    const double v = std::exp(-0.5 * (k / sigma_nodes) * (k / sigma_nodes));
    w[static_cast<std::size_t>(k + radius)] = static_cast<float>(v);
    power += v * v;
  }
  for (auto& v : w) v = static_cast<float>(v / std::sqrt(power));
  return w;
}

// Correlation of the smoothed field between neighbouring nodes.
double neighbourCorrelation(const std::vector<float>& w) {
  double rho = 0.0;
  for (std::size_t k = 0; k + 1 < w.size(); ++k) rho += static_cast<double>(w[k]) * w[k + 1];
  return rho;
}

// Fills `out` with unit-variance uniform white noise (four 16-bit draws per
// 64-bit one); smoothing over ~20 lattice nodes makes it Gaussian (CLT).
void whiteNoise(std::vector<float>& out, SplitMix64& rng) {
  constexpr float kScale = 2.0f * 1.7320508f / 65535.0f;  // [0, 65535] -> [-sqrt 3, sqrt 3]
  std::size_t k = 0;
  while (k < out.size()) {
    std::uint64_t bits = rng.next();
    for (int part = 0; part < 4 && k < out.size(); ++part, bits >>= 16)
      out[k++] = static_cast<float>(bits & 0xFFFF) * kScale - 1.7320508f;
  }
}

// Separable smoothing of a (nx + 2 rx) x (ny + 2 ry) noise block (storage
// [i * (ny + 2 ry) + j]) into nx x ny: w_axial along j, then w_lateral along i.
std::vector<float> smooth(const std::vector<float>& noise, int nx, int ny, const std::vector<float>& w_lateral,
                          const std::vector<float>& w_axial) {
  const int rx = static_cast<int>(w_lateral.size() / 2), ry = static_cast<int>(w_axial.size() / 2);
  const int stride = ny + 2 * ry;
  std::vector<float> axial(static_cast<std::size_t>(nx + 2 * rx) * ny, 0.0f);
  for (int i = 0; i < nx + 2 * rx; ++i) {
    const float* in = noise.data() + static_cast<std::size_t>(i) * stride;
    float* out = axial.data() + static_cast<std::size_t>(i) * ny;
    Eigen::Map<Eigen::ArrayXf> out_column(out, ny);
    for (std::size_t k = 0; k < w_axial.size(); ++k)
      out_column += w_axial[k] * Eigen::Map<const Eigen::ArrayXf>(in + k, ny);
  }
  std::vector<float> field(static_cast<std::size_t>(nx) * ny, 0.0f);
  for (int i = 0; i < nx; ++i) {
    float* out = field.data() + static_cast<std::size_t>(i) * ny;
    Eigen::Map<Eigen::ArrayXf> out_column(out, ny);
    for (std::size_t k = 0; k < w_lateral.size(); ++k)
      out_column +=
          w_lateral[k] * Eigen::Map<const Eigen::ArrayXf>(axial.data() + (static_cast<std::size_t>(i) + k) * ny, ny);
  }
  return field;
}

// Pixel -> lattice cell and fraction along one axis, and the gain restoring
// unit variance: between nodes of correlation rho the interpolated field's
// variance is (1-f)^2 + f^2 + 2 f (1-f) rho < 1.
void axisMapping(int pixels, double spacing_mm, double step_mm, int nodes, double rho, std::vector<int>& cell,
                 std::vector<float>& frac, std::vector<float>& gain) {
  cell.resize(static_cast<std::size_t>(pixels));
  frac.resize(cell.size());
  gain.resize(cell.size());
  for (int p = 0; p < pixels; ++p) {
    const double u = p * spacing_mm / step_mm;
    const int i = std::min(static_cast<int>(u), nodes - 2);
    const double f = u - i;
    const double variance = (1 - f) * (1 - f) + f * f + 2 * f * (1 - f) * rho;
    cell[static_cast<std::size_t>(p)] = i;
    frac[static_cast<std::size_t>(p)] = static_cast<float>(f);
    gain[static_cast<std::size_t>(p)] = static_cast<float>(1.0 / std::sqrt(variance));
  }
}

}  // namespace

SpeckleField::SpeckleField(int width, int height, double spacing_x_mm, double spacing_y_mm, double lateral_psf_mm,
                           double axial_psf_mm, SplitMix64& rng) {
  // Finer than half a pixel buys nothing: the speckle is then uncorrelated
  // from pixel to pixel anyway.
  const double step_x = std::max(lateral_psf_mm / kNodesPerSigma, 0.5 * spacing_x_mm);
  const double step_y = std::max(axial_psf_mm / kNodesPerSigma, 0.5 * spacing_y_mm);
  nx_ = static_cast<int>((width - 1) * spacing_x_mm / step_x) + 2;
  ny_ = static_cast<int>((height - 1) * spacing_y_mm / step_y) + 2;
  const auto w_x = unitPowerKernel(lateral_psf_mm / step_x), w_y = unitPowerKernel(axial_psf_mm / step_y);
  std::vector<float> noise(static_cast<std::size_t>(nx_ + 2 * (w_x.size() / 2)) * (ny_ + 2 * (w_y.size() / 2)));
  whiteNoise(noise, rng);
  re_ = smooth(noise, nx_, ny_, w_x, w_y);
  whiteNoise(noise, rng);
  im_ = smooth(noise, nx_, ny_, w_x, w_y);
  axisMapping(width, spacing_x_mm, step_x, nx_, neighbourCorrelation(w_x), col_cell_, col_frac_, col_gain_);
  axisMapping(height, spacing_y_mm, step_y, ny_, neighbourCorrelation(w_y), row_cell_, row_frac_, row_gain_);
  // Unit-mean Rayleigh envelope: each component's sigma is sqrt(2 / pi).
  for (auto& g : col_gain_) g *= 0.7978846f;
  tmp_re_.resize(static_cast<std::size_t>(ny_));
  tmp_im_.resize(static_cast<std::size_t>(ny_));
}

void SpeckleField::column(int c, std::vector<float>& re, std::vector<float>& im) {
  const auto cu = static_cast<std::size_t>(c);
  const int i = col_cell_[cu];
  const float f = col_frac_[cu], gain = col_gain_[cu];
  const float* re0 = re_.data() + static_cast<std::size_t>(i) * ny_;
  const float* im0 = im_.data() + static_cast<std::size_t>(i) * ny_;
  using Column = Eigen::Map<const Eigen::ArrayXf>;
  Eigen::Map<Eigen::ArrayXf>(tmp_re_.data(), ny_) = gain * ((1.0f - f) * Column(re0, ny_) + f * Column(re0 + ny_, ny_));
  Eigen::Map<Eigen::ArrayXf>(tmp_im_.data(), ny_) = gain * ((1.0f - f) * Column(im0, ny_) + f * Column(im0 + ny_, ny_));
  for (std::size_t r = 0; r < row_cell_.size(); ++r) {
    const auto j = static_cast<std::size_t>(row_cell_[r]);
    const float g = row_frac_[r], row_gain = row_gain_[r];
    re[r] = row_gain * (tmp_re_[j] + g * (tmp_re_[j + 1] - tmp_re_[j]));
    im[r] = row_gain * (tmp_im_[j] + g * (tmp_im_[j + 1] - tmp_im_[j]));
  }
}

}  // namespace mrsns::simulation::detail
