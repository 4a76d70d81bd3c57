#pragma once
// The HMD calibration's data (paper 001 §II.C): the calibration cube's
// definition, the holds of the cube on its hologram, and the solution from
// them (tremor compensation per fiducial, Eq. 12-16; the cube calibration per
// view, Eq. 17; the views averaged, Eq. 18-20). Live acquisition and offline
// recomputation both go through solveCubeHolds, so they give the same numbers.
#include <Eigen/Geometry>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "mrsns/core/mesh.h"
#include "mrsns/core/tracked_frame.h"

namespace mrsns::workflow::detail {

/// A calibration cube: its edge and where it sits on its marker. Its eight
/// vertices (the fiducials P_i^Ver of Eq. 2) are cube_to_marker * (+-e/2,
/// +-e/2, +-e/2), vertex i taking +e/2 on x when bit 0 of i is set, y bit 1,
/// z bit 2. File (JSON): {"format": "mrsns-calibration-cube/1", "name": ...,
/// "edge_mm": 60, "cube_to_marker": [16 numbers, row-major]} (identity when
/// absent: the cube centred on the marker's origin, its faces along its axes).
struct CubeDefinition {
  std::string name;
  std::string file;
  double edge_mm = 0.0;
  Eigen::Isometry3d marker_T_cube = Eigen::Isometry3d::Identity();
  [[nodiscard]] std::vector<Eigen::Vector3d> verticesMarker() const;
  /// The cube as 12 triangles in the marker's frame (the hologram's mesh).
  [[nodiscard]] TriangleMesh mesh() const;
};

/// Throws FileError/FormatError naming the file and what is wrong (an edge outside 10-500 mm, a non-rigid
/// cube_to_marker).
CubeDefinition readCubeDefinition(const std::filesystem::path& file);

/// One accepted hold: the view, where the hologram showed the cube (the marker frame's pose in the headset's
/// world frame), and the stretch of the recording (tracker timestamps) the operator held it there.
struct CubeHold {
  std::string view;
  Eigen::Isometry3d hologram_T_marker = Eigen::Isometry3d::Identity();
  double start = 0.0;
  double end = 0.0;
  std::string confirmed_by;  ///< headset, key
};

struct CubeHoldsOptions {
  std::string transform = "CubeToTracker";
  int k_close = 4;
  double omega = 1.5;
  /// false: paper 001's uncompensated control, each fiducial from the single sample at the confirmation (the
  /// hold's first), as a comparison; the hold is still recorded and judged whole.
  bool tremor_compensation = true;
};

/// One hold's samples: the CubeToTracker poses recorded in [start, end], and how many frames there had none.
struct HoldSamples {
  std::vector<Eigen::Isometry3d> tracker_T_marker;
  int frames = 0;
  int untracked = 0;
};
HoldSamples holdSamples(const std::vector<TrackedFrame>& frames, const CubeHold& hold, const std::string& transform);

struct CubeViewSolution {
  Eigen::Isometry3d tracker_T_hologram = Eigen::Isometry3d::Identity();
  double rigid_rms_mm = 0.0;
  double affine_rms_mm = 0.0;
  double largest_spread_mm = 0.0;  ///< RMS distance of a fiducial's samples from its centre, the widest
  int samples = 0;
  int untracked = 0;
  int dropped = 0;  ///< samples the tremor filter left out, over the 8 fiducials
};
/// Throws InvalidArgumentError when the hold has fewer than k_close + 1 tracked samples.
CubeViewSolution solveCubeHold(const HoldSamples& samples, const CubeHold& hold, const CubeDefinition& cube,
                               const CubeHoldsOptions& options);

struct CubeHoldsSolution {
  Eigen::Isometry3d tracker_T_hologram = Eigen::Isometry3d::Identity();
  std::vector<CubeViewSolution> views;
  double max_pairwise_rotation_deg = 0.0;
  double max_pairwise_translation_mm = 0.0;
  /// Where each view's calibration puts the cube's centre as the hologram showed it: the RMS distance from
  /// their mean (mm). How well the views agree where it matters, not 500 mm away at the hologram's origin.
  double at_cube_rms_mm = 0.0;
};
CubeHoldsSolution solveCubeHolds(const std::vector<TrackedFrame>& frames, const std::vector<CubeHold>& holds,
                                 const CubeDefinition& cube, const CubeHoldsOptions& options);

/// holds.json: the cube, the transform and every accepted hold; read back for source=file.
nlohmann::json holdsJson(const CubeDefinition& cube, const CubeHoldsOptions& options,
                         const std::vector<CubeHold>& holds);
std::vector<CubeHold> holdsFromJson(const nlohmann::json& j, const std::string& what);

/// The holds' samples in the points file of `mrsns-cli hmd-calibrate-cube` (one row per fiducial per sample:
/// the vertex in the marker's frame, the CubeToTracker pose's first three rows, the hologram fiducial).
void writeCubePointsCsv(const std::filesystem::path& file, const std::vector<TrackedFrame>& frames,
                        const std::vector<CubeHold>& holds, const CubeDefinition& cube,
                        const CubeHoldsOptions& options);

}  // namespace mrsns::workflow::detail
