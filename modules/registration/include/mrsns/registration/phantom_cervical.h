#pragma once
// The MR-SNS cervical phantom: a CT-like volume of the neck (C3-C7, soft
// tissue, trachea, a carotid-like vessel, titanium fiducial screws) built from
// analytic primitives, with its label map and the exact geometry it was made
// from (screw entry points, planned pedicle screw paths). No input files: the
// same options give the same volume on any machine (resources/README.md).
#include <Eigen/Core>
#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include "mrsns/core/image.h"
#include "mrsns/core/landmarks.h"
#include "mrsns/registration/screw_path.h"

namespace mrsns::registration {

struct PhantomOptions {
  double spacing_mm = 0.8;  ///< isotropic voxel edge
  std::uint64_t seed = 1;   ///< noise seed
  double noise_sigma_hu = 15.0;
  /// Field of view along x (left), y (posterior), z (superior); the spine is
  /// centred on (0, 0, 0) LPS.
  Eigen::Vector3d extent_mm = Eigen::Vector3d(120.0, 120.0, 140.0);
};

/// Tissue values of the phantom (HU).
struct PhantomDensities {
  static constexpr double air = -1000.0;
  static constexpr double soft_tissue = 40.0;
  static constexpr double cancellous_bone = 300.0;
  static constexpr double cortical_bone = 900.0;
  static constexpr double cortex_thickness_mm = 1.0;
  /// Contrast-enhanced lumen, visible against soft tissue yet below the
  /// default 250 HU bone threshold, so bone segmentation leaves it out.
  static constexpr double vessel_lumen = 150.0;
  static constexpr double vessel_wall = 60.0;
  static constexpr double titanium = 3000.0;
};

struct PhantomVertebra {
  int label = 0;     ///< VerSe numbering: C3..C7 = 3..7
  std::string name;  ///< "C3".."C7"
  /// Vertebra frame -> LPS: origin at the body centre, x left, y posterior, z
  /// along the spine's local axis (superior).
  Eigen::Matrix3d rotation = Eigen::Matrix3d::Identity();
  Eigen::Vector3d body_center = Eigen::Vector3d::Zero();
};

struct PhantomFiducialScrew {
  std::string label;                                ///< "F-1".."F-8"
  std::string vertebra;                             ///< "C3", ...
  Eigen::Vector3d tip = Eigen::Vector3d::Zero();    ///< inside the bone, LPS mm
  Eigen::Vector3d head = Eigen::Vector3d::Zero();   ///< outer end of the head
  Eigen::Vector3d axis = Eigen::Vector3d::UnitY();  ///< unit, from tip to head
  /// Where the axis leaves the bone surface (the screw's landmark).
  Eigen::Vector3d bone_entry = Eigen::Vector3d::Zero();
  double shaft_diameter_mm = 2.0;
  double head_diameter_mm = 3.5;
  double length_mm = 7.0;
};

struct CervicalPhantom {
  ImageVolume ct;      ///< int16 HU, frame "CT"
  ImageVolume labels;  ///< uint8: vertebrae 3..7, vessel 91, screws 92 (screws win where they enter bone)
  /// uint8 vertebra labels of the bone alone (no screw holes): the surface the
  /// fiducial landmarks lie on.
  ImageVolume bone_labels;
  std::vector<PhantomVertebra> vertebrae;
  std::vector<PhantomFiducialScrew> screws;
  LandmarkSet fiducials_truth;  ///< bone_entry of each screw, labels F-1..F-8, frame "CT"
  /// Planned pedicle screws of C5 and C6 (names "C5 left", ...; entry on the
  /// lateral mass, target 3 mm short of the far cortex of the body, 3.5 mm).
  std::vector<ScrewPath> screw_paths;
  std::map<int, std::string> label_names;
  /// The vessel's centre line (a straight tube along z) and radii.
  Eigen::Vector3d vessel_center = Eigen::Vector3d::Zero();
  double vessel_lumen_radius_mm = 3.5;
  double vessel_outer_radius_mm = 4.3;
  double noise_sigma_hu = 0.0;
  std::uint64_t seed = 0;
};

/// Builds the phantom. Throws InvalidArgumentError for a spacing outside
/// [0.2, 3] mm, a negative noise or an extent too small to hold the spine.
[[nodiscard]] CervicalPhantom generateCervicalPhantom(const PhantomOptions& options = {});

/// Signed distance (mm, negative inside) of an LPS point to the phantom's
/// bone surface (all vertebrae, without screws), from the same primitives
/// as the volume.
[[nodiscard]] double phantomBoneDistance(const CervicalPhantom& phantom, const Eigen::Vector3d& p_lps);

}  // namespace mrsns::registration
