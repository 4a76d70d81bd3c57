#pragma once
// B-mode-like ultrasound slices of a vessel (simulation) and a seeded
// hypoechoic-lumen segmentation with an ellipse fit (the feature contours of
// Algorithm 1 without a trained network: CPU, real time, no weights).
//
// Image coordinates: pixel (column c, row r) is at (c * spacing, r * spacing, 0)
// mm in the image frame; x lateral, y depth (away from the transducer face).

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <random>
#include <span>
#include <string>
#include <vector>

#include "mrsns/core/mesh.h"
#include "mrsns/core/plane_intersection.h"

namespace mrsns::deformation {

struct BModeImage {
  int width = 0;
  int height = 0;
  double spacing_mm = 0.2;
  std::vector<float> pixels;  ///< row-major, width * height

  [[nodiscard]] float at(int c, int r) const { return pixels[static_cast<std::size_t>(r) * width + c]; }
  /// Bilinear sample at image coordinates (mm); 0 outside.
  [[nodiscard]] double sample(double x_mm, double y_mm) const;
};

struct BModeSimulationOptions {
  int width = 160;
  int height = 160;
  double spacing_mm = 0.2;
  double tissue_echo = 0.5;
  double lumen_echo = 0.06;
  double wall_echo = 1.0;
  double wall_thickness_mm = 0.6;
  /// Attenuation (per mm of depth, amplitude).
  double attenuation_per_mm = 0.02;
  /// Fully developed speckle: Rayleigh-distributed multiplicative noise,
  /// smoothed over a 3x3 pixel kernel (the resolution cell).
  bool speckle = true;
};

/// Renders the slice of `truth` (model frame) in the plane of `model_T_image`.
[[nodiscard]] BModeImage renderBMode(const TriangleMesh& truth, const Eigen::Isometry3d& model_T_image,
                                     const BModeSimulationOptions& options, std::mt19937_64& rng);

struct LumenSegmentationOptions {
  int rays = 48;
  /// Search along each ray between these multiples of the seed radius.
  double search_min = 0.3;
  double search_max = 2.2;
  double step_mm = 0.1;
  /// Points further than this many MADs (and 0.4 mm) from the first fit are dropped.
  double outlier_mads = 3.0;
  /// Resampled points of the output contour.
  int contour_points = 64;
  /// The seed centre may move this far (mm) to the darkest disc nearby.
  double capture_range_mm = 4.0;
  /// Refuse a result whose centre moved more than this fraction of the seed radius.
  double max_center_shift = 1.2;
  /// Seeds whose discs overlap (two branch loops of the model's cut near a
  /// bifurcation) are segmented each from its own centre, with the rays that
  /// point into the other seed's disc left out (there the two lumens merge and
  /// no wall is seen); false refuses them as ambiguous.
  bool split_overlapping = true;
  /// Fewest rays (fraction of `rays`) left after the cones towards the other
  /// seeds are removed: a shorter arc does not constrain an ellipse.
  double min_ray_fraction = 0.55;
};

struct LumenContour {
  bool ok = false;
  std::string status;
  Polyline3d contour;  ///< Closed, image coordinates (mm, z = 0).
  Eigen::Vector2d center = Eigen::Vector2d::Zero();
  double semi_major_mm = 0.0;
  double semi_minor_mm = 0.0;
  double fit_rms_mm = 0.0;  ///< Radial RMS of the inlier edge points to the ellipse.
  int inliers = 0;
  /// Segmented from an overlapping seed with the shared side left out.
  bool split = false;
};

/// For each seed contour (image coordinates, e.g. the model's predicted
/// contour), finds the dark lumen near the seed's centre (the darkest disc of
/// the seed's size within the capture range), casts rays from it to
/// the first rise above the lumen/tissue midpoint, and fits an ellipse
/// (Halir-Flusser direct least squares) with one round of outlier rejection.
/// Seeds whose discs overlap another seed are segmented from their own
/// centre without the rays towards the other seed (`split_overlapping`), or
/// reported as not ok (ambiguous) when that leaves too short an arc.
[[nodiscard]] std::vector<LumenContour> segmentLumens(const BModeImage& image, std::span<const Polyline3d> seeds,
                                                      const LumenSegmentationOptions& options = {});

struct Ellipse2d {
  Eigen::Vector2d center = Eigen::Vector2d::Zero();
  Eigen::Vector2d axis1 = Eigen::Vector2d::UnitX();  ///< unit direction of semi-axis a
  double a = 0.0;
  double b = 0.0;
  [[nodiscard]] Eigen::Vector2d point(double angle) const;
};

/// Direct least-squares ellipse fit (Fitzgibbon 1999, Halir-Flusser 1998).
/// Returns false for fewer than 5 points or a degenerate (non-ellipse) fit.
bool fitEllipse(std::span<const Eigen::Vector2d> points, Ellipse2d& ellipse);

}  // namespace mrsns::deformation
