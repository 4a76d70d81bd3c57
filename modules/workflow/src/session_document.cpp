// JSON forms of the typed session content (session_document.h).
#include "mrsns/workflow/session_document.h"

#include <cctype>
#include <cmath>
#include <initializer_list>

#include "mrsns/core/error.h"

namespace mrsns::workflow {

using Json = nlohmann::json;

namespace {

Json vec3(const Eigen::Vector3d& v) {
  return Json::array({v.x(), v.y(), v.z()});
}

Eigen::Vector3d readVec3(const Json& j, const char* key, const Eigen::Vector3d& fallback) {
  if (!j.contains(key)) return fallback;
  const Json& v = j.at(key);
  if (!v.is_array() || v.size() != 3 || !v[0].is_number() || !v[1].is_number() || !v[2].is_number()) {
    throw FormatError(std::string("session.json: '") + key + "' must be three numbers, got " + v.dump());
  }
  return {v[0].get<double>(), v[1].get<double>(), v[2].get<double>()};
}

Json mat3(const Eigen::Matrix3d& m) {
  Json rows = Json::array();
  for (int r = 0; r < 3; ++r) rows.push_back(Json::array({m(r, 0), m(r, 1), m(r, 2)}));
  return rows;
}

Eigen::Matrix3d readMat3(const Json& j, const char* key) {
  Eigen::Matrix3d m = Eigen::Matrix3d::Identity();
  if (!j.contains(key)) return m;
  const Json& v = j.at(key);
  if (!v.is_array() || v.size() != 3) throw FormatError(std::string("session.json: '") + key + "' must be 3 rows");
  for (int r = 0; r < 3; ++r) {
    const Json& row = v[static_cast<std::size_t>(r)];
    if (!row.is_array() || row.size() != 3) throw FormatError(std::string("session.json: '") + key + "' row size");
    for (int c = 0; c < 3; ++c) m(r, c) = row[static_cast<std::size_t>(c)].get<double>();
  }
  return m;
}

Json mat4(const Eigen::Matrix4d& m) {
  Json out = Json::array();
  for (int r = 0; r < 4; ++r) {
    for (int c = 0; c < 4; ++c) out.push_back(m(r, c));
  }
  return out;
}

Eigen::Matrix4d readMat4(const Json& j, const char* key) {
  Eigen::Matrix4d m = Eigen::Matrix4d::Identity();
  if (!j.contains(key)) return m;
  const Json& v = j.at(key);
  if (!v.is_array() || v.size() != 16) {
    throw FormatError(std::string("session.json: '") + key + "' must be 16 numbers (a row-major 4x4 matrix)");
  }
  for (int i = 0; i < 16; ++i) {
    const Json& x = v[static_cast<std::size_t>(i)];
    if (!x.is_number()) throw FormatError(std::string("session.json: '") + key + "' holds a value that is not a number");
    m(i / 4, i % 4) = x.get<double>();
  }
  return m;
}

// A number that may be absent (NaN) is stored as null, which JSON can hold.
Json optionalNumber(double v) {
  return std::isfinite(v) ? Json(v) : Json(nullptr);
}

double readOptionalNumber(const Json& j, const char* key) {
  if (!j.contains(key) || j.at(key).is_null()) return std::numeric_limits<double>::quiet_NaN();
  return j.at(key).get<double>();
}

template <typename T>
T value(const Json& j, const char* key, const T& fallback) {
  if (!j.contains(key) || j.at(key).is_null()) return fallback;
  try {
    return j.at(key).get<T>();
  } catch (const Json::exception&) {
    throw FormatError(std::string("session.json: '") + key + "' has the wrong type: " + j.at(key).dump());
  }
}

void requireObject(const Json& j, const char* what) {
  if (!j.is_object()) throw FormatError(std::string("session.json: a ") + what + " entry is not an object");
}

}  // namespace

std::string modelRoleName(ModelRole role) {
  switch (role) {
    case ModelRole::Bone: return "bone";
    case ModelRole::SoftTissue: return "soft_tissue";
    case ModelRole::Vessel: return "vessel";
    case ModelRole::Neural: return "neural";
    case ModelRole::Fiducial: return "fiducial";
    case ModelRole::Other: return "other";
  }
  return "other";
}

namespace {

std::string lowerText(std::string s) {
  for (auto& c : s) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return s;
}

bool containsAny(const std::string& text, std::initializer_list<const char*> words) {
  for (const char* w : words) {
    if (text.find(w) != std::string::npos) return true;
  }
  return false;
}

}  // namespace

std::string vertebraName(const std::string& name) {
  std::string s = name;
  if (s.rfind("vertebrae_", 0) == 0) s = s.substr(10);
  if (s.size() < 2 || s.size() > 3) return {};
  const char region = static_cast<char>(std::toupper(static_cast<unsigned char>(s[0])));
  if (region != 'C' && region != 'T' && region != 'L' && region != 'S') return {};
  for (std::size_t i = 1; i < s.size(); ++i) {
    if (!std::isdigit(static_cast<unsigned char>(s[i]))) return {};
  }
  const int number = std::stoi(s.substr(1));
  const int most = region == 'C' ? 7 : region == 'T' ? 13 : region == 'L' ? 6 : 5;
  if (number < 1 || number > most) return {};
  return std::string(1, region) + s.substr(1);
}

ModelRole structureRole(const std::string& name) {
  const std::string n = lowerText(name);
  if (!vertebraName(name).empty()) return ModelRole::Bone;
  if (containsAny(n, {"spinal_cord", "spinal cord", "cord", "nerve", "dural", "thecal", "canal"})) {
    return ModelRole::Neural;
  }
  if (containsAny(n, {"screw", "fiducial", "marker", "implant"})) return ModelRole::Fiducial;
  if (containsAny(n, {"arter", "aorta", "vein", "vena", "vessel", "carotid", "brachiocephalic_trunk", "jugular",
                      "iliac_a", "iliac_v"})) {
    return ModelRole::Vessel;
  }
  if (containsAny(n, {"vertebra", "bone", "rib", "sacrum", "hip", "femur", "humerus", "scapula", "clavicul",
                      "sternum", "skull", "pelvis", "costal_cartilage", "mandible", "odontoid"})) {
    return ModelRole::Bone;
  }
  if (containsAny(n, {"spleen", "kidney", "liver", "gallbladder", "stomach", "pancreas", "adrenal", "lung",
                      "esophagus", "trachea", "thyroid", "bowel", "duodenum", "colon", "bladder", "prostate",
                      "heart", "brain", "muscle", "gluteus", "autochthon", "iliopsoas", "psoas", "tissue", "skin",
                      "fat", "appendage", "organ"})) {
    return ModelRole::SoftTissue;
  }
  return ModelRole::Other;
}

Eigen::Vector3d roleColor(ModelRole role) {
  switch (role) {
    case ModelRole::Bone: return {0.93, 0.89, 0.80};
    case ModelRole::Vessel: return {0.80, 0.10, 0.10};
    case ModelRole::Neural: return {0.95, 0.85, 0.25};
    case ModelRole::SoftTissue: return {0.85, 0.45, 0.42};
    case ModelRole::Fiducial: return {0.60, 0.65, 0.75};
    case ModelRole::Other: break;
  }
  return {0.70, 0.70, 0.70};
}

ModelRole modelRoleFromName(const std::string& name) {
  if (name == "bone") return ModelRole::Bone;
  if (name == "soft_tissue" || name == "soft-tissue") return ModelRole::SoftTissue;
  if (name == "vessel") return ModelRole::Vessel;
  if (name == "neural") return ModelRole::Neural;
  if (name == "fiducial") return ModelRole::Fiducial;
  if (name == "other") return ModelRole::Other;
  throw InvalidArgumentError("model role '" + name + "' is not one of bone, soft_tissue, vessel, neural, fiducial, other");
}

std::string transformKind(const std::string& name) {
  if (name.rfind("CTTo", 0) == 0 || name == "PhantomToReference") return "registration";
  return "calibration";
}

void to_json(Json& j, const Provenance& p) {
  j = Json{{"source", p.source}, {"time", p.time}, {"simulated", p.simulated}};
  if (!p.step.empty()) j["step"] = p.step;
  if (!p.file.empty()) j["file"] = p.file;
  if (!p.quality.empty()) j["quality"] = p.quality;
}

void from_json(const Json& j, Provenance& p) {
  requireObject(j, "provenance");
  p.source = value<std::string>(j, "source", "");
  p.step = value<std::string>(j, "step", "");
  p.file = value<std::string>(j, "file", "");
  p.time = value<std::string>(j, "time", "");
  p.simulated = value<bool>(j, "simulated", false);
  p.quality = j.contains("quality") ? j.at("quality") : Json::object();
}

void to_json(Json& j, const ImageEntry& e) {
  j = Json{{"id", e.id},
           {"role", e.role},
           {"file", e.file},
           {"name", e.name},
           {"frame", e.frame},
           {"format", e.format},
           {"modality", e.modality},
           {"size_px", e.size_px},
           {"spacing_mm", vec3(e.spacing_mm)},
           {"origin_mm", vec3(e.origin_mm)},
           {"direction", mat3(e.direction)},
           {"pixel_type", e.pixel_type},
           {"value_range", Json::array({e.value_min, e.value_max})},
           {"provenance", e.provenance}};
  if (!e.series_uid.empty()) j["series_uid"] = e.series_uid;
  if (!e.series_description.empty()) j["series_description"] = e.series_description;
}

void from_json(const Json& j, ImageEntry& e) {
  requireObject(j, "image");
  e.id = value<std::string>(j, "id", "ct");
  e.role = value<std::string>(j, "role", "ct");
  e.file = value<std::string>(j, "file", "");
  e.name = value<std::string>(j, "name", "");
  e.frame = value<std::string>(j, "frame", "CT");
  e.format = value<std::string>(j, "format", "");
  e.modality = value<std::string>(j, "modality", "");
  e.series_uid = value<std::string>(j, "series_uid", "");
  e.series_description = value<std::string>(j, "series_description", "");
  e.size_px = value<std::array<int, 3>>(j, "size_px", {0, 0, 0});
  e.spacing_mm = readVec3(j, "spacing_mm", Eigen::Vector3d::Ones());
  e.origin_mm = readVec3(j, "origin_mm", Eigen::Vector3d::Zero());
  e.direction = readMat3(j, "direction");
  e.pixel_type = value<std::string>(j, "pixel_type", "");
  const auto range = value<std::vector<double>>(j, "value_range", {0.0, 0.0});
  e.value_min = range.size() == 2 ? range[0] : 0.0;
  e.value_max = range.size() == 2 ? range[1] : 0.0;
  e.provenance = value<Provenance>(j, "provenance", {});
}

void to_json(Json& j, const LabelEntry& e) {
  j = Json{{"value", e.value}, {"name", e.name}, {"voxels", e.voxels}, {"role", e.role}};
}

void from_json(const Json& j, LabelEntry& e) {
  requireObject(j, "label");
  e.value = value<int>(j, "value", 0);
  e.name = value<std::string>(j, "name", "");
  e.voxels = value<std::size_t>(j, "voxels", 0);
  e.role = value<std::string>(j, "role", "");
}

void to_json(Json& j, const LabelMapEntry& e) {
  j = Json{{"id", e.id},           {"file", e.file},     {"name", e.name},
           {"scheme", e.scheme},   {"placement", e.placement}, {"labels", e.labels},
           {"provenance", e.provenance}};
}

void from_json(const Json& j, LabelMapEntry& e) {
  requireObject(j, "label map");
  e.id = value<std::string>(j, "id", "");
  e.file = value<std::string>(j, "file", "");
  e.name = value<std::string>(j, "name", "");
  e.scheme = value<std::string>(j, "scheme", "");
  e.placement = value<std::string>(j, "placement", "same-grid");
  e.labels = value<std::vector<LabelEntry>>(j, "labels", {});
  e.provenance = value<Provenance>(j, "provenance", {});
}

void to_json(Json& j, const ModelEntry& e) {
  j = Json{{"id", e.id},
           {"name", e.name},
           {"file", e.file},
           {"frame", e.frame},
           {"role", modelRoleName(e.role)},
           {"color", vec3(e.color)},
           {"opacity", e.opacity},
           {"visible", e.visible},
           {"triangles", e.triangles},
           {"volume_ml", e.volume_ml},
           {"provenance", e.provenance}};
  if (!e.hmd_file.empty()) {
    j["hmd_file"] = e.hmd_file;
    j["hmd_triangles"] = e.hmd_triangles;
  }
  if (!e.vertebra.empty()) j["vertebra"] = e.vertebra;
  if (!e.label_map.empty()) {
    j["label_map"] = e.label_map;
    j["label"] = e.label;
  }
  if (std::isfinite(e.threshold_hu)) j["threshold_hu"] = e.threshold_hu;
  if (e.voxel_volume_ml > 0.0) {
    j["voxel_volume_ml"] = e.voxel_volume_ml;
    j["volume_tolerance_ml"] = e.volume_tolerance_ml;
  }
}

void from_json(const Json& j, ModelEntry& e) {
  requireObject(j, "model");
  e.id = value<std::string>(j, "id", "");
  e.name = value<std::string>(j, "name", e.id);
  e.file = value<std::string>(j, "file", "");
  e.hmd_file = value<std::string>(j, "hmd_file", "");
  e.frame = value<std::string>(j, "frame", "CT");
  e.role = modelRoleFromName(value<std::string>(j, "role", "other"));
  e.color = readVec3(j, "color", Eigen::Vector3d(0.9, 0.9, 0.9));
  e.opacity = value<double>(j, "opacity", 1.0);
  e.visible = value<bool>(j, "visible", true);
  e.vertebra = value<std::string>(j, "vertebra", "");
  e.label_map = value<std::string>(j, "label_map", "");
  e.label = value<int>(j, "label", 0);
  e.threshold_hu = readOptionalNumber(j, "threshold_hu");
  e.triangles = value<std::size_t>(j, "triangles", 0);
  e.hmd_triangles = value<std::size_t>(j, "hmd_triangles", 0);
  e.volume_ml = value<double>(j, "volume_ml", 0.0);
  e.voxel_volume_ml = value<double>(j, "voxel_volume_ml", 0.0);
  e.volume_tolerance_ml = value<double>(j, "volume_tolerance_ml", 0.0);
  e.provenance = value<Provenance>(j, "provenance", {});
}

void to_json(Json& j, const ShapeModelEntry& e) {
  j = Json{{"id", e.id},
           {"file", e.file},
           {"name", e.name},
           {"role", modelRoleName(e.role)},
           {"model_to_ct", mat4(e.ct_T_model)},
           {"components", e.components},
           {"points", e.points},
           {"mean_model", e.mean_model},
           {"provenance", e.provenance}};
}

void from_json(const Json& j, ShapeModelEntry& e) {
  requireObject(j, "shape model");
  e.id = value<std::string>(j, "id", "soft-tissue");
  e.file = value<std::string>(j, "file", "");
  e.name = value<std::string>(j, "name", "");
  e.role = modelRoleFromName(value<std::string>(j, "role", "soft_tissue"));
  e.ct_T_model = readMat4(j, "model_to_ct");
  e.components = value<int>(j, "components", 0);
  e.points = value<std::size_t>(j, "points", 0);
  e.mean_model = value<std::string>(j, "mean_model", "");
  e.provenance = value<Provenance>(j, "provenance", {});
}

void to_json(Json& j, const FiducialPoint& e) {
  j = Json{{"label", e.label},
           {"position_ct", vec3(e.position_ct)},
           {"source", e.source},
           {"confidence", optionalNumber(e.confidence)}};
  if (e.axis_ct.norm() > 0.0) j["axis_ct"] = vec3(e.axis_ct);
}

void from_json(const Json& j, FiducialPoint& e) {
  requireObject(j, "fiducial");
  e.label = value<std::string>(j, "label", "");
  e.position_ct = readVec3(j, "position_ct", Eigen::Vector3d::Zero());
  e.source = value<std::string>(j, "source", "");
  e.confidence = readOptionalNumber(j, "confidence");
  e.axis_ct = readVec3(j, "axis_ct", Eigen::Vector3d::Zero());
}

void to_json(Json& j, const FiducialSet& e) {
  j = Json{{"file", e.file}, {"frame", e.frame}, {"points", e.points}, {"provenance", e.provenance}};
}

void from_json(const Json& j, FiducialSet& e) {
  requireObject(j, "fiducials");
  e.file = value<std::string>(j, "file", "");
  e.frame = value<std::string>(j, "frame", "CT");
  e.points = value<std::vector<FiducialPoint>>(j, "points", {});
  e.provenance = value<Provenance>(j, "provenance", {});
}

void to_json(Json& j, const PlannedScrew& e) {
  j = Json{{"name", e.name},
           {"vertebra", e.vertebra},
           {"side", e.side},
           {"entry", vec3(e.entry)},
           {"target", vec3(e.target)},
           {"diameter_mm", e.diameter_mm},
           {"length_mm", e.length_mm},
           {"figures", e.figures},
           {"provenance", e.provenance}};
}

void from_json(const Json& j, PlannedScrew& e) {
  requireObject(j, "planned screw");
  e.name = value<std::string>(j, "name", "");
  e.vertebra = value<std::string>(j, "vertebra", "");
  e.side = value<std::string>(j, "side", "");
  e.entry = readVec3(j, "entry", Eigen::Vector3d::Zero());
  e.target = readVec3(j, "target", Eigen::Vector3d::Zero());
  e.diameter_mm = value<double>(j, "diameter_mm", 3.5);
  e.length_mm = value<double>(j, "length_mm", 0.0);
  e.figures = j.contains("figures") ? j.at("figures") : Json::object();
  e.provenance = value<Provenance>(j, "provenance", {});
}

void to_json(Json& j, const TransformEntry& e) {
  j = Json{{"name", e.name}, {"kind", e.kind}, {"matrix", mat4(e.matrix)}, {"provenance", e.provenance}};
  if (!e.file.empty()) j["file"] = e.file;
}

void from_json(const Json& j, TransformEntry& e) {
  requireObject(j, "transform");
  e.name = value<std::string>(j, "name", "");
  e.kind = value<std::string>(j, "kind", transformKind(e.name));
  e.matrix = readMat4(j, "matrix");
  e.file = value<std::string>(j, "file", "");
  e.provenance = value<Provenance>(j, "provenance", {});
}

void to_json(Json& j, const RecordingEntry& e) {
  j = Json{{"file", e.file}, {"kind", e.kind}, {"provenance", e.provenance}};
}

void from_json(const Json& j, RecordingEntry& e) {
  requireObject(j, "recording");
  e.file = value<std::string>(j, "file", "");
  e.kind = value<std::string>(j, "kind", "other");
  e.provenance = value<Provenance>(j, "provenance", {});
}

}  // namespace mrsns::workflow
