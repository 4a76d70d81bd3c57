#pragma once
// A carotid-like bifurcating vessel for the simulated protocol of paper 001
// §III.A: common carotid (CCA) splitting into internal (ICA) and external
// (ECA) branches, each an open tube with the same topology for every shape,
// deformed by random "thread-like stretches" (smooth local pulls of the
// centre line) and radius changes.

#include <Eigen/Core>
#include <random>
#include <vector>

#include "mrsns/core/mesh.h"

namespace mrsns::deformation {

struct VesselPhantomOptions {
  int ring_vertices = 24;
  double ring_spacing_mm = 1.0;
  double cca_length_mm = 30.0;
  double branch_length_mm = 30.0;
  double cca_radius_mm = 3.5;
  double ica_radius_mm = 2.8;
  double eca_radius_mm = 2.2;
  /// Lateral separation (mm) of the branch centre lines at the branch end.
  double branch_spread_mm = 9.0;
};

/// Deformation of one phantom shape: per branch (CCA, ICA, ECA) pulls of the
/// centre line (x, y amplitude in mm at a position along the branch with a
/// width), a radius scale, and a change of the branch spread.
struct VesselDeformation {
  struct Pull {
    int branch = 0;                                          ///< 0 CCA, 1 ICA, 2 ECA
    double position = 0.5;                                   ///< along the branch, 0..1
    double width = 0.3;                                      ///< Gaussian width, fraction of the branch
    Eigen::Vector2d amplitude_mm = Eigen::Vector2d::Zero();  ///< x (lateral), y (depth)
  };
  std::vector<Pull> pulls;
  Eigen::Vector3d radius_scale = Eigen::Vector3d::Ones();
  double spread_scale = 1.0;
};

/// Random stretches: `pull_count` pulls of `amplitude_mm` RMS per axis,
/// radius scales of `radius_sd` relative SD, spread scale of `spread_sd`.
[[nodiscard]] VesselDeformation randomVesselDeformation(std::mt19937_64& rng, int pull_count = 4,
                                                        double amplitude_mm = 2.0, double radius_sd = 0.08,
                                                        double spread_sd = 0.1);

/// The phantom mesh (frame "Phantom": z along the CCA towards the head, y
/// depth away from the skin, x lateral). Identical topology for every deformation.
[[nodiscard]] TriangleMesh makeVesselPhantom(const VesselDeformation& deformation,
                                             const VesselPhantomOptions& options = {});

/// Seven well-spread vertex indices (the fiducial vertices of Eq. 21).
[[nodiscard]] std::vector<int> phantomFiducialVertices(const VesselPhantomOptions& options = {});

}  // namespace mrsns::deformation
