#pragma once
// B-mode ultrasound frames of the simulated world at the probe's current
// image plane: the N-wire phantom's wires in a water bath, the patient's bone
// surfaces with their acoustic shadows and the vessel lumen, in tissue with
// fully developed speckle and depth attenuation.
//
// Image frame (as the ultrasound module's, PLUS "MF" orientation): pixel
// (column c, row r) lies at (c * spacing_x, r * spacing_y, 0) mm; x lateral,
// y depth away from the transducer face (row 0), beams along +y.
#include <Eigen/Geometry>
#include <cstdint>
#include <functional>
#include <optional>
#include <vector>

namespace mrsns::simulation {

/// A thin wire (N-wire phantom), end points in the scene frame (mm).
struct EchoWire {
  Eigen::Vector3d a = Eigen::Vector3d::Zero();
  Eigen::Vector3d b = Eigen::Vector3d::UnitX();
  double radius_mm = 0.25;
};

/// An anechoic water bath (a box): inside it only the wires echo.
struct EchoBox {
  Eigen::Isometry3d scene_T_box = Eigen::Isometry3d::Identity();
  Eigen::Vector3d half_extent_mm = Eigen::Vector3d(50.0, 50.0, 50.0);
};

/// What the beam can meet, all in one scene frame. Empty functions mean
/// "absent". Distances are signed (mm, negative inside).
struct EchoScene {
  std::vector<EchoWire> wires;
  std::optional<EchoBox> water_bath;
  std::function<double(const Eigen::Vector3d&)> bone_distance_mm;
  std::function<double(const Eigen::Vector3d&)> vessel_distance_mm;
};

struct BModeGeometry {
  int width = 640;
  int height = 480;
  double spacing_x_mm = 0.1;
  double spacing_y_mm = 0.1;
};

/// The image-formation and noise model (stated beside every simulated figure).
struct BModeNoiseModel {
  double tissue_echo = 70.0;           ///< mean grey level of soft tissue at the face
  double lumen_echo = 8.0;             ///< mean grey level inside the vessel lumen
  double water_echo = 3.0;             ///< mean grey level of the water bath
  double bone_echo = 230.0;            ///< the bright bone surface
  double wire_echo = 220.0;            ///< peak of a wire's dot
  double attenuation_db_per_cm = 1.0;  ///< round trip, tissue only (water: none)
  double lateral_psf_mm = 0.35;        ///< Gaussian sigma of the point spread, lateral
  double axial_psf_mm = 0.2;           ///< Gaussian sigma, axial
  bool speckle = true;                 ///< Rayleigh speckle, correlated over the PSF
  double electronic_noise = 2.0;       ///< additive Gaussian grey-level sigma
};

/// Renders one 8-bit frame (row-major, width * height) of `scene` in the
/// plane of `scene_T_image`. Deterministic for a given frame_seed.
/// Throws InvalidArgumentError for a non-positive size or spacing.
[[nodiscard]] std::vector<std::uint8_t> renderBModeFrame(const EchoScene& scene, const Eigen::Isometry3d& scene_T_image,
                                                         const BModeGeometry& geometry, const BModeNoiseModel& noise,
                                                         std::uint64_t frame_seed);

}  // namespace mrsns::simulation
