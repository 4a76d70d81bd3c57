#pragma once
// Fully developed speckle: the echo of many random sub-resolution scatterers
// is a circular complex Gaussian field correlated over the point spread
// function, whose envelope is Rayleigh distributed. The field is made on a
// lattice finer than the PSF (white noise smoothed by a Gaussian kernel, so
// its correlation matches the PSF's) and read per pixel by bilinear
// interpolation, with the variance loss of interpolation compensated so the
// mean brightness does not show the lattice.
#include <cstdint>
#include <vector>

namespace mrsns::simulation::detail {

/// splitmix64: tiny, fast and good enough for noise; one stream per frame seed.
class SplitMix64 {
 public:
  explicit SplitMix64(std::uint64_t seed) : state_(seed) {}
  std::uint64_t next() {
    std::uint64_t z = (state_ += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
  }
  /// Two approximately standard normal numbers from one 64-bit draw: each
  /// the sum of four uniform bytes (Irwin-Hall: variance 4 (256^2 - 1) / 12).
  /// Tails stop at 3.5 sigma and steps are 0.014 sigma: irrelevant for
  /// grey-level noise, and twice as cheap as 16-bit parts.
  void normalPair(float& a, float& b) {
    const std::uint64_t bits = next();
    constexpr std::uint64_t kBytes = 0x000000FF000000FFull;
    const std::uint64_t sums =
        (bits & kBytes) + ((bits >> 8) & kBytes) + ((bits >> 16) & kBytes) + ((bits >> 24) & kBytes);
    constexpr float kMean = 2.0f * 255.0f, kScale = 0.00676588f;  // 1 / sqrt(4 (256^2 - 1) / 12)
    a = (static_cast<float>(sums & 0xFFFFFFFFull) - kMean) * kScale;
    b = (static_cast<float>(sums >> 32) - kMean) * kScale;
  }

 private:
  std::uint64_t state_;
};

class SpeckleField {
 public:
  /// Lattice nodes per PSF sigma: enough for bilinear interpolation to look
  /// smooth, few enough to stay cheap.
  static constexpr double kNodesPerSigma = 1.5;

  /// The field over an image of width x height pixels at the given spacing,
  /// correlated over the Gaussian PSF (sigmas in mm).
  SpeckleField(int width, int height, double spacing_x_mm, double spacing_y_mm, double lateral_psf_mm,
               double axial_psf_mm, SplitMix64& rng);

  /// Complex speckle of image column c, every row, with E|z| = 1 (a
  /// Rayleigh envelope of unit mean): written to re/im (size height).
  void column(int c, std::vector<float>& re, std::vector<float>& im);

 private:
  int nx_ = 0, ny_ = 0;  ///< lattice nodes (lateral, axial); storage [i * ny + j]
  std::vector<float> re_, im_;
  // Per image column / row: lattice cell, fraction, and the gain that restores
  // unit variance between nodes.
  std::vector<int> col_cell_, row_cell_;
  std::vector<float> col_frac_, row_frac_, col_gain_, row_gain_;
  std::vector<float> tmp_re_, tmp_im_;  ///< the column's lateral interpolation, per lattice row
};

}  // namespace mrsns::simulation::detail
