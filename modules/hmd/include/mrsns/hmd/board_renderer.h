#pragma once
// A simulated camera image of a checkerboard: the board (inner corners as in
// checkerboard_grid.h, one white square of border around the outer squares)
// seen from a known pose through a known camera with lens distortion, with
// supersampled anti-aliasing, Gaussian optical blur and additive Gaussian
// sensor noise. Used by the simulated protocol of paper 000 and by tests, so
// corner detection and calibration run on real pixels.
#include <Eigen/Geometry>
#include <cstdint>

#include "mrsns/hmd/camera_calibration.h"
#include "mrsns/hmd/checkerboard_grid.h"

namespace mrsns::hmd {

struct BoardRenderOptions {
  double blur_sigma_px = 0.7;  // optics + demosaicing
  double noise_sigma = 2.0;    // grey levels, additive Gaussian
  int supersample = 2;         // samples per pixel along each axis
  std::uint8_t dark = 25, light = 225, background = 110;
  unsigned seed = 1;
};

/// Renders the board at camera_T_grid (grid -> camera, mm). Pixels whose ray misses the board
/// (or points away from it) show the background.
GrayImage renderCheckerboard(const CheckerboardSpec& spec, const CameraIntrinsics& intrinsics,
                             const Eigen::Isometry3d& camera_T_grid, const BoardRenderOptions& options = {});

}  // namespace mrsns::hmd
