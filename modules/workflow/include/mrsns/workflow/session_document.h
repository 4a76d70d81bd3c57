#pragma once
// The typed content of a session (session.json version 2): the patient's CT
// and label maps, the models made from them, the soft-tissue shape model,
// the fiducials in image space, the planned screws, the calibrations and
// registrations and the recordings, each with where it came from. The GUI's
// scene, the CLI and the steps ask the session for "the CT", "the bone
// models", "the plan" or "the last StylusTipToStylus" through these types;
// nothing guesses from a file name (Slicer's MRML scene and CustusX's patient
// file are the model). Every file is named relative to the session folder.
#include <Eigen/Core>
#include <array>
#include <cstddef>
#include <limits>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

namespace mrsns::workflow {

/// Where an entry came from.
struct Provenance {
  /// "file" (imported from the user's file), "step" (computed by a workflow
  /// step), "user" (placed or edited by hand in the GUI or the CLI),
  /// "migration" (found in a version-1 session when it was upgraded).
  std::string source;
  std::string step;  ///< the step that made or imported it ("import-ct", "registration", ...)
  std::string file;  ///< the user's original file or folder, for imports (absolute, as given)
  std::string time;  ///< ISO-8601 UTC
  /// Produced by a simulated device (mrsns-sim, the in-process simulator): such a
  /// result is never presented as a measurement of the real patient or device.
  bool simulated = false;
  nlohmann::json quality = nlohmann::json::object();  ///< the figures that judge it (RMS, residuals, volumes)
};

/// The patient's image (the CT every model, fiducial and plan is expressed in).
struct ImageEntry {
  std::string id = "ct";
  std::string role = "ct";
  std::string file;   ///< in the session, e.g. "ct/CT.nrrd"
  std::string name;   ///< shown to the user
  std::string frame = "CT";
  std::string format;  ///< of the original: "nifti", "nrrd", "metaimage", "dicom"
  std::string modality;  ///< DICOM modality of the original ("CT"); empty when the format has none
  std::string series_uid;
  std::string series_description;
  std::array<int, 3> size_px{0, 0, 0};
  Eigen::Vector3d spacing_mm = Eigen::Vector3d::Ones();
  Eigen::Vector3d origin_mm = Eigen::Vector3d::Zero();  ///< LPS centre of voxel (0, 0, 0)
  Eigen::Matrix3d direction = Eigen::Matrix3d::Identity();
  std::string pixel_type;
  double value_min = 0.0, value_max = 0.0;  ///< HU
  Provenance provenance;
};

struct LabelEntry {
  int value = 0;
  std::string name;
  std::size_t voxels = 0;
  std::string role;  ///< modelRoleName of what it is ("bone", "vessel", ...)
};

/// A label map on the CT's grid.
struct LabelMapEntry {
  std::string id;    ///< "labels", "labels-2", ...
  std::string file;  ///< in the session, on the CT's grid
  std::string name;
  std::string scheme;  ///< "totalsegmentator", "verse", "generic"
  /// How it was put on the CT's grid: "same-grid" (as given), "embedded" (a crop
  /// of the CT's grid placed in it), "resampled" (nearest neighbour onto it),
  /// "aligned" (a crop whose header is stale, shifted by whole voxels onto the
  /// label map it shares vertebrae with: import-label-map align_to=).
  std::string placement = "same-grid";
  std::vector<LabelEntry> labels;
  Provenance provenance;
};

/// What a model is, for the planning figures and the display: bone (what a
/// screw must stay in), vessels and neural structures (what it must stay away
/// from), other soft tissue, fiducial screws or markers, anything else.
enum class ModelRole { Bone, SoftTissue, Vessel, Neural, Fiducial, Other };

/// "bone", "soft_tissue", "vessel", "neural", "fiducial", "other".
[[nodiscard]] std::string modelRoleName(ModelRole role);
/// Inverse of modelRoleName (also "soft-tissue"); throws InvalidArgumentError naming the accepted names.
[[nodiscard]] ModelRole modelRoleFromName(const std::string& name);
/// The role of a structure by its label name (TotalSegmentator, VerSe, the
/// phantom's, or a mask's file name): vertebrae, ribs, pelvis and long bones
/// are bone; arteries and veins vessels; the spinal cord neural; screws,
/// fiducials, markers and implants fiducial; organs and muscles soft tissue;
/// anything unknown other.
[[nodiscard]] ModelRole structureRole(const std::string& name);
/// "L1" from "vertebrae_L1", "L1", "C5"; empty when the name is not a vertebra's.
[[nodiscard]] std::string vertebraName(const std::string& name);
/// A display colour for a role (vessels red, neural yellow, bone ivory, ...).
[[nodiscard]] Eigen::Vector3d roleColor(ModelRole role);

/// A surface model in the CT's frame.
struct ModelEntry {
  std::string id;    ///< unique in the session ("L1", "aorta", "bone")
  std::string name;  ///< shown to the user
  std::string file;  ///< full-detail mesh in the session (CT mm, LPS)
  std::string hmd_file;  ///< decimated copy for the headset; empty when none was made
  std::string frame = "CT";
  ModelRole role = ModelRole::Other;
  Eigen::Vector3d color = Eigen::Vector3d(0.9, 0.9, 0.9);
  double opacity = 1.0;
  bool visible = true;
  std::string vertebra;   ///< "L1", "C5" for a vertebra model; empty otherwise
  std::string label_map;  ///< the label map it was meshed from (its id), empty otherwise
  int label = 0;          ///< its label value there
  double threshold_hu = std::numeric_limits<double>::quiet_NaN();  ///< for a model from a threshold
  std::size_t triangles = 0;
  std::size_t hmd_triangles = 0;
  double volume_ml = 0.0;  ///< enclosed by the mesh
  double voxel_volume_ml = 0.0;  ///< of the voxels it was made from (0 when not from voxels)
  double volume_tolerance_ml = 0.0;  ///< expected |mesh - voxels| from the voxel size
  Provenance provenance;
};

/// A statistical shape model of soft tissue (statismo HDF5) placed in the CT.
struct ShapeModelEntry {
  std::string id = "soft-tissue";
  std::string file;  ///< statismo .h5 in the session
  std::string name;
  ModelRole role = ModelRole::SoftTissue;
  Eigen::Matrix4d ct_T_model = Eigen::Matrix4d::Identity();
  int components = 0;
  std::size_t points = 0;
  std::string mean_model;  ///< the id of the model showing its mean shape
  Provenance provenance;
};

struct FiducialPoint {
  std::string label;  ///< "F-1"
  Eigen::Vector3d position_ct = Eigen::Vector3d::Zero();  ///< LPS mm in the CT
  /// How it was found: "label" (a screw/marker label), "threshold" (metal in
  /// the CT), "placed" (clicked by the user), "file" (imported).
  std::string source;
  double confidence = std::numeric_limits<double>::quiet_NaN();  ///< of an automatic find, in [0, 1]
  /// Unit axis of the fiducial screw out of the bone, when it was found from
  /// the screw; zero when unknown (placed or imported points).
  Eigen::Vector3d axis_ct = Eigen::Vector3d::Zero();
};

struct FiducialSet {
  std::string file;  ///< the Slicer markups copy kept in step with the points
  std::string frame = "CT";
  std::vector<FiducialPoint> points;
  Provenance provenance;
};

/// A planned pedicle screw in the CT.
struct PlannedScrew {
  std::string name;      ///< "L1 left"
  std::string vertebra;  ///< "L1"
  std::string side;      ///< "left", "right" or empty
  Eigen::Vector3d entry = Eigen::Vector3d::Zero();   ///< LPS mm, where it enters the bone
  Eigen::Vector3d target = Eigen::Vector3d::Zero();  ///< LPS mm, the planned tip direction
  double diameter_mm = 3.5;
  double length_mm = 0.0;  ///< <= 0: |target - entry|
  /// Clearance to soft tissue and vessels, cortical breach, angles to the
  /// vertebra's axes (registration::evaluateScrewPlan), recomputed on each change.
  nlohmann::json figures = nlohmann::json::object();
  Provenance provenance;
};

/// A calibration or registration result: the ChildToParent transform of its name.
struct TransformEntry {
  std::string name;  ///< PLUS style, "CTToPatient" (parent_T_child: patient_T_ct)
  std::string kind;  ///< "calibration" or "registration"
  Eigen::Matrix4d matrix = Eigen::Matrix4d::Identity();
  std::string file;  ///< the transform file the step wrote, when it wrote one
  Provenance provenance;
};

/// A recording a step kept (tracking, video, a calibration data set).
struct RecordingEntry {
  std::string file;
  std::string kind;  ///< "tracking", "video", "dataset", "other"
  Provenance provenance;
};

/// "registration" for the registrations MR-SNS makes (CTToPatient,
/// PhantomToReference, ...), "calibration" for everything else.
[[nodiscard]] std::string transformKind(const std::string& name);

// JSON forms (the layout of session.json version 2; modules/workflow/doc/session.md).
void to_json(nlohmann::json& j, const Provenance& p);
void from_json(const nlohmann::json& j, Provenance& p);
void to_json(nlohmann::json& j, const ImageEntry& e);
void from_json(const nlohmann::json& j, ImageEntry& e);
void to_json(nlohmann::json& j, const LabelEntry& e);
void from_json(const nlohmann::json& j, LabelEntry& e);
void to_json(nlohmann::json& j, const LabelMapEntry& e);
void from_json(const nlohmann::json& j, LabelMapEntry& e);
void to_json(nlohmann::json& j, const ModelEntry& e);
void from_json(const nlohmann::json& j, ModelEntry& e);
void to_json(nlohmann::json& j, const ShapeModelEntry& e);
void from_json(const nlohmann::json& j, ShapeModelEntry& e);
void to_json(nlohmann::json& j, const FiducialPoint& e);
void from_json(const nlohmann::json& j, FiducialPoint& e);
void to_json(nlohmann::json& j, const FiducialSet& e);
void from_json(const nlohmann::json& j, FiducialSet& e);
void to_json(nlohmann::json& j, const PlannedScrew& e);
void from_json(const nlohmann::json& j, PlannedScrew& e);
void to_json(nlohmann::json& j, const TransformEntry& e);
void from_json(const nlohmann::json& j, TransformEntry& e);
void to_json(nlohmann::json& j, const RecordingEntry& e);
void from_json(const nlohmann::json& j, RecordingEntry& e);

}  // namespace mrsns::workflow
