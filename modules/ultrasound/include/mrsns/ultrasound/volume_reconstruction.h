#pragma once
// Freehand 3D ultrasound: tracked frames placed in a volume's space (the
// "reslice of the frame into a volume" of the image chain), as PLUS's
// VolumeReconstructor does it: every pixel splatted into the 8 voxels
// around its position with trilinear weights, overlapping frames averaged,
// small holes between sweeps filled from their neighbours. The opposite
// direction, a volume (e.g. the CT) sampled on a frame's plane for overlays,
// is here too.
#include <Eigen/Geometry>
#include <array>
#include <cstdint>
#include <span>
#include <vector>

#include "mrsns/core/image.h"
#include "mrsns/ultrasound/nwire_segmentation.h"

namespace mrsns::ultrasound {

/// An axis-aligned grid (in the target frame) that holds every given image
/// corner with `margin_mm` around it, voxels of `spacing_mm`. Throws
/// InvalidArgumentError for a non-positive spacing, no corners, or a grid of
/// more than `max_voxels` voxels (the message gives the size to try).
ImageVolume gridAroundCorners(const std::vector<Eigen::Vector3d>& corners_mm, double spacing_mm, double margin_mm,
                              std::size_t max_voxels = 512u * 512u * 512u);

struct ReconstructionFigures {
  std::size_t frames = 0;
  std::size_t pixels_inside = 0;   ///< pixels that landed in the grid
  std::size_t pixels_outside = 0;  ///< pixels that fell outside it
  double filled_fraction = 0.0;    ///< voxels with data after hole filling
  std::size_t holes_filled = 0;
};

/// Accumulates frames into the grid of `grid` (its geometry only; pixel data
/// ignored). Frames are single-channel 8-bit MF images; `grid_T_image` maps
/// pixel (u, v, 0) to mm in the grid's frame (target_T_image of the chain,
/// with the pixel spacing in its first two columns).
class VolumeReconstructor {
 public:
  /// `threads` splat a frame and fill holes in parallel (0 = the hardware's);
  /// the result does not depend on it.
  explicit VolumeReconstructor(const ImageVolume& grid, unsigned threads = 0);

  /// `clip` (x, y, width, height in pixels) limits the frame to its image
  /// area (no text or bars); empty = whole frame. Throws InvalidArgumentError
  /// when the pixel count does not match the size.
  void addFrame(const GrayImageView& frame, const Eigen::Matrix4d& grid_T_image, std::array<int, 4> clip = {});

  /// The compounded volume (uint8, mean of the contributions; 0 where no
  /// frame reached), holes up to `hole_radius_voxels` filled from the
  /// weighted neighbours.
  [[nodiscard]] ImageVolume result(int hole_radius_voxels = 1);
  [[nodiscard]] const ReconstructionFigures& figures() const { return figures_; }

 private:
  // Sum of weighted values and of weights side by side: a splat touches
  // both, so they share a cache line.
  struct Accumulated {
    float sum = 0.0f;
    float weight = 0.0f;
  };
  ImageVolume grid_;
  unsigned threads_ = 0;
  std::vector<Accumulated> accumulator_;
  ReconstructionFigures figures_;
};

/// The volume sampled (trilinear, in its own LPS mm space) at every pixel of
/// a width x height frame placed by `volume_T_image` (pixel -> LPS mm);
/// `outside` where the pixel lies outside the volume. Row-major, x fastest.
std::vector<float> sampleVolumeOnFrame(const ImageVolume& volume, const Eigen::Matrix4d& volume_T_image, int width,
                                       int height, float outside = 0.0f);

}  // namespace mrsns::ultrasound
