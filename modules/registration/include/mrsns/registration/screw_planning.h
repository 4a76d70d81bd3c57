#pragma once
// The figures a surgeon reads beside each planned pedicle screw: the
// vertebra's anatomical frame (from its closed mesh), the screw's medial and
// cranial angles in that frame, how far the screw leaves the bone (cortical
// breach, Gertzbein-Robbins grade) and its clearance to structures to avoid,
// with warnings in a surgeon's words. LPS millimetres inside; degrees only in
// the `_deg` figures. Definitions and conventions:
// modules/registration/doc/README.md, "Screw planning figures".
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <array>
#include <cstddef>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "mrsns/core/mesh.h"
#include "mrsns/core/mesh_locator.h"
#include "mrsns/registration/screw_path.h"

namespace mrsns::registration {

// ---------------------------------------------------------------------------
// The vertebra's anatomical frame

struct VertebraFrameOptions {
  /// The spine's local superior direction in LPS (any length), e.g. from the
  /// centroid of the vertebra below to the one above. When set it replaces
  /// the superior axis (left is the principal left axis made orthogonal to
  /// it, posterior = superior x left), and the principal axes are assigned to
  /// the patient axes turned onto it (so a steep lordosis does not swap
  /// them). Signed to agree with +z; refused when zero, not finite or more
  /// than 80 deg from +z.
  std::optional<Eigen::Vector3d> superior_hint;
  /// Below this `confidence` the frame is flagged ambiguous (0.2: a vertebra
  /// turned ~37 deg about one patient axis).
  double min_confidence = 0.2;
  /// Below this `moment_separation` the frame is flagged ambiguous (two
  /// principal axes are then ill-defined in their plane).
  double min_moment_separation = 0.02;
};

/// An orthonormal, right-handed frame of a vertebra in LPS:
/// left x posterior = superior.
struct VertebraFrame {
  /// Centroid of the enclosed volume (divergence theorem), LPS mm.
  Eigen::Vector3d origin = Eigen::Vector3d::Zero();
  Eigen::Vector3d left = Eigen::Vector3d::UnitX();       ///< unit, towards the patient's left (+x)
  Eigen::Vector3d posterior = Eigen::Vector3d::UnitY();  ///< unit, towards posterior (+y)
  Eigen::Vector3d superior = Eigen::Vector3d::UnitZ();   ///< unit, towards superior (+z)
  double volume_mm3 = 0.0;                               ///< enclosed volume
  /// Smallest and largest offset of the mesh's vertices from the origin
  /// along (left, posterior, superior), and their difference (mm).
  Eigen::Vector3d extent_min_mm = Eigen::Vector3d::Zero();
  Eigen::Vector3d extent_max_mm = Eigen::Vector3d::Zero();
  Eigen::Vector3d extent_mm = Eigen::Vector3d::Zero();
  /// Principal axes of the enclosed volume's inertia as assigned and signed
  /// (columns left, posterior, superior), before a hint replaced superior.
  Eigen::Matrix3d principal_axes = Eigen::Matrix3d::Identity();
  /// RMS radius of the enclosed volume about the origin along each principal
  /// axis (square root of the volume-weighted second moment, mm), same order.
  Eigen::Vector3d principal_rms_mm = Eigen::Vector3d::Zero();
  /// Mean |cos| between the principal axes and the patient axes they were
  /// assigned to: 1 when they coincide.
  double alignment = 0.0;
  /// (best sum of |cos| over the 6 assignments - the second best) / 2, in
  /// [0, 1]: 1 for axes on the patient axes, 0 when another assignment fits
  /// as well (a vertebra turned 45 deg about one patient axis); cos t - sin t
  /// for a turn by t about one axis.
  double confidence = 0.0;
  /// Smallest gap between two principal second moments over the largest, in
  /// [0, 1]: near 0 the two axes of that pair are ill-defined.
  double moment_separation = 0.0;
  bool ambiguous = false;           ///< confidence or moment_separation below the options' minimum
  bool superior_from_hint = false;  ///< the superior axis is the options' hint
  /// Angle between the hint and the principal superior axis (rad); 0 without a hint.
  double hint_angle = 0.0;
  /// What a caller should tell the user (ambiguity, a corrected handedness).
  std::vector<std::string> warnings;

  /// Columns left, posterior, superior.
  [[nodiscard]] Eigen::Matrix3d rotation() const;
  /// Maps vertebra coordinates (left, posterior, superior; mm from the origin) to LPS.
  [[nodiscard]] Eigen::Isometry3d lps_T_vertebra() const;
};

/// The anatomical frame of a closed, outward-wound vertebra mesh (LPS mm):
/// origin at the centroid of the enclosed volume, axes from the principal
/// axes of its inertia, each assigned to the patient axis it is closest to
/// (the best of the 6 permutations by the sum of |cos|) and signed to agree
/// with it. Throws InvalidArgumentError naming the mesh when it is invalid,
/// has no faces, is not closed, is inside-out, encloses no volume or is flat,
/// or for an unusable hint.
[[nodiscard]] VertebraFrame vertebraFrame(const TriangleMesh& vertebra, const VertebraFrameOptions& options = {});

// ---------------------------------------------------------------------------
// Screw angles

struct ScrewAngleOptions {
  /// An entry closer than this to the vertebra's mid-sagittal plane (along
  /// `left`) has no medial side: side "midline", medial_deg NaN.
  double midline_tolerance_mm = 1.0;
};

struct ScrewAngles {
  /// Transverse (axial) angle: between the screw direction projected on the
  /// axial plane (left, posterior) and anterior (-posterior), positive when
  /// the screw converges towards the mid-sagittal plane (tip more medial
  /// than the entry). In (-180, 180]: beyond +-90 the projection points
  /// posteriorly (never flipped). NaN for a midline entry or a screw along
  /// the superior axis.
  double medial_deg = 0.0;
  /// Sagittal angle: between the screw direction and the axial plane,
  /// positive towards superior, in [-90, 90].
  double cranial_deg = 0.0;
  /// The axial angle from anterior, positive towards the vertebra's left
  /// (side-independent: medial_deg = axial_deg on the right, -axial_deg on
  /// the left). NaN for a screw along the superior axis.
  double axial_deg = 0.0;
  std::string side;                   ///< "left", "right" or "midline", from the entry's offset along `left`
  double entry_offset_left_mm = 0.0;  ///< (entry - origin) . left
  /// Unit screw direction in the frame: (left, posterior, superior) components.
  Eigen::Vector3d direction_in_frame = Eigen::Vector3d::Zero();
  /// The direction has a posterior component: the screw points backwards,
  /// out of the vertebra (usually entry and target swapped).
  bool points_posteriorly = false;
};

/// The screw's angles in the vertebra's frame. Throws as validateScrewPath.
[[nodiscard]] ScrewAngles screwAngles(const ScrewPath& path, const VertebraFrame& frame,
                                      const ScrewAngleOptions& options = {});

// ---------------------------------------------------------------------------
// Cortical breach

struct BreachOptions {
  double step_mm = 0.5;            ///< axial sampling step
  int circumference_samples = 12;  ///< points around the screw's surface per station (>= 3)
  /// Length of the axis below the entry not counted as a breach (the screw
  /// head sits at the cortex); empty: the screw radius.
  std::optional<double> entry_allowance_mm;
};

/// Gertzbein-Robbins grade of a breach b (mm): A (0) none, B (1) b < 2,
/// C (2) 2 <= b < 4, D (3) 4 <= b < 6, E (4) b >= 6.
enum class GertzbeinRobbins { A = 0, B = 1, C = 2, D = 3, E = 4 };
[[nodiscard]] GertzbeinRobbins gertzbeinRobbinsGrade(double breach_mm);
[[nodiscard]] char gertzbeinRobbinsLetter(GertzbeinRobbins grade);

struct BreachSample {
  double depth_mm = 0.0;                 ///< from the entry along the axis
  double axis_signed_distance_mm = 0.0;  ///< of the axis point to the bone: negative inside
  /// Largest signed distance of this station's surface samples; empty when
  /// not evaluated (before the allowance, or the axis deeper inside than the
  /// radius so the whole circumference is inside).
  std::optional<double> surface_max_signed_distance_mm;
  bool surface_outside = false;  ///< some surface sample lies outside (depth >= allowance)
};

struct BoneBreach {
  /// Length of the axis outside the bone beyond the allowance (mm).
  double axis_outside_mm = 0.0;
  /// Axial length beyond the allowance over which some surface sample is outside (mm).
  double surface_outside_mm = 0.0;
  /// How far the screw's surface leaves the bone: the largest distance of a
  /// surface point outside it beyond the allowance (mm); 0 when none is outside.
  double max_breach_mm = 0.0;
  /// The largest signed distance of a surface point beyond the allowance
  /// (mm): max_breach_mm when positive; otherwise minus the margin by which
  /// the thread stays inside the cortex.
  double max_signed_distance_mm = 0.0;
  double depth_of_max_breach_mm = 0.0;                             ///< where that point is (from the entry)
  Eigen::Vector3d max_breach_point = Eigen::Vector3d::Zero();      ///< that point on the screw's surface, LPS
  Eigen::Vector3d max_breach_direction = Eigen::Vector3d::Zero();  ///< unit, from the axis out to it
  /// Length of the axis inside the bone over the whole screw (mm).
  double length_in_bone_mm = 0.0;
  /// Signed distance of the entry to the bone (mm): negative inside; a
  /// well-placed entry is on or just inside the surface.
  double entry_to_bone_mm = 0.0;
  int grade = 0;                    ///< Gertzbein-Robbins 0..4
  char grade_letter = 'A';          ///< 'A'..'E'
  double entry_allowance_mm = 0.0;  ///< the allowance used
  double screw_length_mm = 0.0;
  std::vector<double> axis_crossings_mm;  ///< depths where the axis crosses the bone surface
  std::vector<BreachSample> profile;      ///< every station from the entry to the tip
  std::size_t distance_queries = 0;       ///< signed-distance queries spent (cost figure)

  [[nodiscard]] bool breached() const { return max_breach_mm > 0.0; }
};

/// The screw (a cylinder of diameter_mm from the entry over
/// effectiveLength()) against a closed bone surface: stations every step_mm
/// from the entry, plus the allowance and the tip; signed distance of the
/// axis at each, crossings refined between stations; circumference_samples
/// points around the surface at each station beyond the allowance (skipped
/// where the axis is deeper inside than the radius: the signed distance is
/// 1-Lipschitz), the largest refined around the best sample. Throws
/// InvalidArgumentError for an unusable path (validateScrewPath), an open
/// bone surface, step_mm <= 0, fewer than 3 circumference samples or a
/// negative allowance.
[[nodiscard]] BoneBreach screwBoneBreach(const ScrewPath& path, const MeshLocator& bone,
                                         const BreachOptions& options = {});

// ---------------------------------------------------------------------------
// One call for the planning panel

enum class StructureKind { Vessel = 0, SoftTissue = 1, Neural = 2, Other = 3 };
inline constexpr std::size_t kStructureKindCount = 4;
/// "vessel", "soft_tissue", "neural", "other".
[[nodiscard]] std::string_view structureKindName(StructureKind kind);

struct BoneStructure {
  std::string name;                      ///< e.g. "L2"
  const MeshLocator* surface = nullptr;  ///< closed bone surface; not owned, must outlive the call
  /// The vertebra's frame (vertebraFrame() of its mesh, computed once when
  /// it is loaded); without it the angles are not computed.
  std::optional<VertebraFrame> frame;
};

struct AvoidanceStructure {
  std::string name;  ///< e.g. "aorta"
  StructureKind kind = StructureKind::Other;
  const MeshLocator* surface = nullptr;  ///< not owned, must outlive the call
};

struct PlanningAnatomy {
  std::vector<BoneStructure> vertebrae;
  std::vector<AvoidanceStructure> avoidance;
};

struct ScrewPlanOptions {
  BreachOptions breach;
  ClearanceOptions clearance;
  ScrewAngleOptions angles;
  /// Warn when a structure of the kind comes closer to the screw's surface
  /// than this (mm); a structure the screw cuts is always named.
  std::array<double, kStructureKindCount> warn_within_mm = {2.0, 1.0, 2.0, 2.0};  // vessel, soft tissue, neural, other
  double warn_entry_outside_mm = 1.0;  ///< warn when the entry lies farther than this outside the bone
  double warn_entry_inside_mm = 3.0;   ///< warn when the entry lies deeper than this inside the bone
};

/// How the screw's vertebra was chosen.
enum class VertebraSource {
  Named,           ///< ScrewPath::vertebra names one of the anatomy's vertebrae
  MostAxisInBone,  ///< the vertebra holding the most of the screw axis
  NearestToEntry,  ///< no vertebra holds any of the axis: the one nearest to the entry
  None,            ///< the anatomy has no vertebra
};
/// "named by the plan", "most of the axis in bone", "nearest to the entry", "none".
[[nodiscard]] std::string_view vertebraSourceName(VertebraSource source);

struct StructureClearance {
  std::string name;
  StructureKind kind = StructureKind::Other;
  /// Screw surface to the structure (mm), as screwPathClearance: negative
  /// when the screw cuts it (-radius where the axis crosses or lies inside).
  double min_clearance_mm = 0.0;
  double depth_mm = 0.0;  ///< where, from the entry
  bool cuts = false;      ///< the screw cuts or lies in the structure
  /// The whole axis lies inside the (closed) structure: no crossing, entry inside.
  bool inside = false;
  PathClearance clearance;  ///< the full profile
};

/// The closest structure of one kind; every figure absent when the anatomy
/// holds none of that kind.
struct KindClearance {
  StructureKind kind = StructureKind::Other;
  std::size_t structures = 0;          ///< how many of this kind the anatomy holds
  std::optional<std::size_t> closest;  ///< index into ScrewPlanFigures::clearances
  std::optional<std::string> name;
  std::optional<double> min_clearance_mm;
  bool cuts = false;
};

struct ScrewPlanFigures {
  std::string screw;     ///< the path's name
  std::string vertebra;  ///< the vertebra measured against; empty when none
  VertebraSource vertebra_from = VertebraSource::None;
  /// Axis length inside each vertebra considered for the choice (mm), by
  /// name; empty when the plan named its vertebra.
  std::vector<std::pair<std::string, double>> axis_in_bone_mm;
  std::optional<ScrewAngles> angles;                       ///< absent without a vertebra or its frame
  std::optional<BoneBreach> breach;                        ///< absent without a vertebra
  std::vector<StructureClearance> clearances;              ///< one per avoidance structure, in the anatomy's order
  std::array<KindClearance, kStructureKindCount> by_kind;  ///< indexed by StructureKind
  std::vector<std::string> warnings;                       ///< most serious first, in a surgeon's words

  [[nodiscard]] const KindClearance& closest(StructureKind kind) const {
    return by_kind[static_cast<std::size_t>(kind)];
  }
};

/// Everything the planning panel shows for one screw: picks its vertebra
/// (ScrewPath::vertebra when it names one, else the one holding the most of
/// the axis), the angles in that vertebra's frame, the breach against it,
/// the clearance to each avoidance structure and the closest of each kind,
/// and the warnings. Throws InvalidArgumentError for an unusable path, a
/// structure without a surface or an open bone surface.
[[nodiscard]] ScrewPlanFigures evaluateScrewPlan(const ScrewPath& path, const PlanningAnatomy& anatomy,
                                                 const ScrewPlanOptions& options = {});

}  // namespace mrsns::registration
