// The step table and the dispatch of runStep().
#include "mrsns/workflow/steps.h"

#include <chrono>
#include <cmath>
#include <filesystem>

#include "mrsns/core/error.h"
#include "mrsns/core/log.h"
#include "step_internal.h"

namespace mrsns::workflow {

std::vector<StepInfo> listSteps() {
  std::vector<StepInfo> steps = {
      {"import-ct", "Import CT", "preparation",
       "The patient's CT (NIfTI, NRRD, MetaImage, a DICOM file or series folder, series=): checked to be a CT in "
       "Hounsfield units, stored in the session with its geometry",
       "data"},
      {"import-label-map", "Import label map", "preparation",
       "A label map of the CT (TotalSegmentator, VerSe or any integer labels): checked against the CT's geometry, "
       "its labels named with their role",
       "data"},
      {"make-models", "Make models", "preparation",
       "Surface models from the label map's labels (source=labels) or a bone threshold (source=threshold): volume "
       "checked against the voxels, a light copy for the headset",
       "data"},
      {"import-phantom", "Phantom patient data", "preparation",
       "MR-SNS's cervical phantom as a patient: its CT, segmentation and planned screws generated as make-phantom "
       "writes them, then imported (CT, label map, bone and vessel models, fiducials found in the CT, plan)",
       "data"},
      {"import-model", "Import model", "preparation",
       "A surface mesh in the CT's frame (STL, VTP, VTK, OBJ, PLY) with its role and colour", "data"},
      {"shape-model", "Soft-tissue shape model", "preparation",
       "The statistical shape model of the critical soft tissue (statismo .h5, or built from meshes in "
       "correspondence), placed in the CT",
       "data"},
      {"find-fiducials", "Find fiducials", "preparation",
       "The fiducials in the CT: on a screw or marker label, on metal above a threshold, or from a markups file",
       "planning"},
      {"place-fiducial", "Place fiducial", "preparation",
       "A fiducial placed (or moved, or removed) by hand at a point of the CT", "planning"},
      {"plan-screw", "Plan screw", "preparation",
       "A pedicle screw by its entry and target in the CT, diameter, length, vertebra and side: clearance to soft "
       "tissue and vessels, cortical breach, angles to the vertebra's axes",
       "planning"},
      {"import-plan", "Import plan", "preparation", "Planned screws from a 3D Slicer markups file of lines",
       "planning"},
      {"export-plan", "Export plan", "preparation", "The planned screws as a 3D Slicer markups file of lines",
       "planning"},
      {"connect-devices", "Connect devices", "preparation",
       "Tracker (simulated, PlusServer over OpenIGTLink, or playback of a PLUS recording): tools seen, rate, jitter",
       "devices"},
      {"pivot-calibration", "Tool pivot calibration", "preparation",
       "Tip of the stylus (or drill) from pivoting it in a divot, recorded live from the PlusServer",
       "calibration"},
      {"spin-calibration", "Tool spin calibration", "preparation",
       "Shaft of the stylus from turning it about its shaft with the tip in the divot (after its pivot calibration): "
       "the tip's whole frame, recorded live from the PlusServer",
       "calibration"},
      {"drill-calibration", "Drill pivot calibration", "preparation",
       "Tip of the drill on the robot's flange (marker FlangeToTracker) from pivoting it by hand in a divot "
       "(freedrive), recorded live from the PlusServer",
       "calibration"},
      {"drill-spin-calibration", "Drill spin calibration", "preparation",
       "Axis of the drill on the robot's flange from turning it about its axis with the tip in the divot (after the "
       "drill's pivot calibration): the drilling direction navigation uses",
       "calibration"},
      {"us-phantom-registration", "Ultrasound phantom registration", "preparation",
       "PhantomToReference from the N-wire phantom's landmarks touched with the calibrated stylus (fCal's phantom "
       "registration), recorded live from the PlusServer",
       "registration"},
      {"us-spatial-calibration", "Ultrasound spatial calibration", "preparation",
       "N-wire calibration of ImageToProbe from a live sweep (source=plus) or a tracked recording (PLUS fCal data by "
       "default)",
       "calibration"},
      {"us-temporal-calibration", "Ultrasound temporal calibration", "preparation",
       "Tracker lag behind the video, from the same N-wire recording (reprojection error over lags)",
       "calibration"},
      {"robot-calibration", "Robot calibration", "preparation",
       "RobotBase to tracker calibration from flange-marker positions",
       "calibration"},
      {"registration", "Patient registration", "preparation",
       "Landmarks then surface (ICP) registration of the CT models to the patient",
       "registration"},
      {"hmd-calibration", "HMD calibration", "preparation",
       "Hologram (HoloLens) to tracker calibration with the calibration cube (Eq. 2-3)",
       "calibration"},
      {"checkerboard-digitisation", "Checkerboard digitisation", "preparation",
       "The tracked checkerboard's corners touched with the calibrated stylus (paper 000 §2.3): GridToBoard and the "
       "digitised corners the HMD camera calibration uses",
       "calibration"},
      {"hmd-camera-calibration", "HMD camera calibration", "preparation",
       "The headset camera in the headset marker's frame (CameraToHeadset) from the headset's photos of the tracked "
       "checkerboard (paper 000's hand-eye method)",
       "calibration"},
      {"navigation", "Navigation", "function",
       "Tracking -> repository -> deformation -> supervisor -> hologram stream, every stream recorded",
       "navigation"},
      {"robot-placement", "Robot-assisted placement", "function",
       "Robot-guided pedicle screw placement on the planned paths: entry, target and angle errors",
       "navigation"},
  };
  return steps;
}

StepResult runStep(Session& session, const std::string& step, const nlohmann::json& params,
                   const StepContext& context) {
  using Runner = StepResult (*)(Session&, const nlohmann::json&, const StepContext&);
  static const std::pair<const char*, Runner> kRunners[] = {
      {"import-ct", detail::runImportCt},
      {"import-label-map", detail::runImportLabelMap},
      {"make-models", detail::runMakeModels},
      {"import-model", detail::runImportModel},
      {"import-phantom", detail::runImportPhantom},
      {"shape-model", detail::runShapeModel},
      {"find-fiducials", detail::runFindFiducials},
      {"place-fiducial", detail::runPlaceFiducial},
      {"plan-screw", detail::runPlanScrew},
      {"import-plan", detail::runImportPlan},
      {"export-plan", detail::runExportPlan},
      {"connect-devices", detail::runConnectDevices},
      {"pivot-calibration", detail::runPivotCalibration},
      {"drill-calibration", detail::runDrillCalibration},
      {"spin-calibration", detail::runSpinCalibration},
      {"drill-spin-calibration", detail::runDrillSpinCalibration},
      {"us-phantom-registration", detail::runUsPhantomRegistration},
      {"us-spatial-calibration", detail::runUsSpatialCalibration},
      {"us-temporal-calibration", detail::runUsTemporalCalibration},
      {"robot-calibration", detail::runRobotCalibration},
      {"registration", detail::runRegistration},
      {"hmd-calibration", detail::runHmdCalibration},
      {"checkerboard-digitisation", detail::runCheckerboardDigitisation},
      {"hmd-camera-calibration", detail::runHmdCameraCalibration},
      {"navigation", detail::runNavigation},
      {"robot-placement", detail::runRobotPlacement},
  };
  Runner runner = nullptr;
  std::string names;
  for (const auto& [name, fn] : kRunners) {
    if (step == name) runner = fn;
    names += names.empty() ? name : std::string(", ") + name;
  }
  if (runner == nullptr) {
    throw InvalidArgumentError("unknown workflow step '" + step + "': use one of " + names);
  }
  if (!params.is_null() && !params.is_object()) {
    throw InvalidArgumentError("parameters of step '" + step + "' must be a JSON object of name: value");
  }
  const nlohmann::json p = params.is_null() ? nlohmann::json::object() : params;
  const auto start = std::chrono::steady_clock::now();
  StepResult result;
  context.report(0.0, "starting " + step);
  try {
    detail::checkCancel(context);  // cancelled before it started: nothing is read or written
    result = runner(session, p, context);
  } catch (const detail::Cancelled&) {
    result = StepResult{};
    result.cancelled = true;
    result.summary = step + " cancelled";
  }
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  if (!result.cancelled) context.report(1.0, result.summary);
  nlohmann::json record = {{"status", result.cancelled ? "cancelled" : (result.ok ? "ok" : "failed")},
                           {"summary", result.summary},
                           {"figures", result.figures},
                           {"outputs", result.outputs},
                           {"params", p},
                           {"seconds", seconds}};
  session.recordStep(step, record);
  session.log(result.ok ? "info" : "warn", step + ": " + result.summary);
  logger()->info("step {}: {}", step, result.summary);
  return result;
}

namespace detail {

std::string freeSessionName(const Session& session, const std::string& folder, const std::string& stem,
                            const std::string& ext) {
  std::filesystem::create_directories(session.resolve(folder));
  for (int n = 1;; ++n) {
    const std::string name = folder + "/" + stem + (n == 1 ? "" : "_" + std::to_string(n)) + ext;
    if (!std::filesystem::exists(session.resolve(name))) return name;
  }
}

tracking::IgtlSourceOptions plusClientOptions(const std::string& host, int port) {
  if (port <= 0 || port > 65535) {
    throw InvalidArgumentError("PlusServer port " + std::to_string(port) + " is not in 1..65535");
  }
  tracking::IgtlSourceOptions igtl;
  igtl.client.host = host;
  igtl.client.port = static_cast<std::uint16_t>(port);
  igtl.identify_device = true;
  return igtl;
}

void sessionPlusServer(const Session& session, const Params& p, std::string& host, int& port) {
  const auto devices = session.step("connect-devices");
  if (devices.is_object() && devices.value("status", "") == "ok" && devices.contains("params") &&
      devices["params"].value("source", "") == "plus") {
    host = devices["params"].value("host", host);
    port = devices["params"].value("port", port);
  }
  host = p.text("host", host);
  port = p.integer("port", port);
}

Params::Params(const std::string& step, const Json& params, std::initializer_list<const char*> known)
    : step_(step), params_(params) {
  std::set<std::string> names(known.begin(), known.end());
  for (const auto& [key, value] : params_.items()) {
    if (names.count(key) == 0) {
      std::string list;
      for (const auto& n : names) list += list.empty() ? n : ", " + n;
      throw InvalidArgumentError("step '" + step + "' has no parameter '" + key + "'" +
                                 (list.empty() ? std::string(" (it takes none)") : "; it takes: " + list));
    }
  }
}

void Params::wrongType(const std::string& key, const char* expected) const {
  throw InvalidArgumentError("step '" + step_ + "' parameter '" + key + "' = " + params_.at(key).dump() + " is not " +
                             expected);
}

double Params::number(const std::string& key, double fallback) const {
  if (!params_.contains(key)) return fallback;
  const auto& v = params_.at(key);
  if (!v.is_number() || !std::isfinite(v.get<double>())) wrongType(key, "a finite number");
  return v.get<double>();
}

int Params::integer(const std::string& key, int fallback) const {
  if (!params_.contains(key)) return fallback;
  const auto& v = params_.at(key);
  if (!v.is_number_integer()) wrongType(key, "an integer");
  return v.get<int>();
}

bool Params::boolean(const std::string& key, bool fallback) const {
  if (!params_.contains(key)) return fallback;
  const auto& v = params_.at(key);
  if (!v.is_boolean()) wrongType(key, "true or false");
  return v.get<bool>();
}

std::string Params::text(const std::string& key, const std::string& fallback) const {
  if (!params_.contains(key)) return fallback;
  const auto& v = params_.at(key);
  // A command line gives series=2 or labels=31 as numbers (--param values are read as JSON): the text they stand for.
  if (v.is_number_integer() || v.is_number_unsigned()) return v.dump();
  if (v.is_number_float()) return v.dump();
  if (!v.is_string()) wrongType(key, "a string");
  return v.get<std::string>();
}

Json matrixJson(const Eigen::Matrix4d& m) {
  Json out = Json::array();
  for (int r = 0; r < 4; ++r) {
    for (int c = 0; c < 4; ++c) out.push_back(m(r, c));
  }
  return out;
}

Eigen::Matrix4d matrixFromJson(const Json& j, const std::string& what) {
  if (!j.is_array() || j.size() != 16) {
    throw FormatError(what + " must be 16 numbers (a row-major 4x4 matrix)");
  }
  Eigen::Matrix4d m;
  for (int i = 0; i < 16; ++i) {
    if (!j[static_cast<std::size_t>(i)].is_number()) throw FormatError(what + " holds a value that is not a number");
    m(i / 4, i % 4) = j[static_cast<std::size_t>(i)].get<double>();
  }
  return m;
}

std::optional<double> recordedStepFigure(const Session& session, const std::string& step, const std::string& key) {
  const Json record = session.step(step);
  if (!record.is_object() || record.value("status", "") != "ok" || !record.contains("figures")) return std::nullopt;
  const Json& f = record["figures"];
  if (!f.is_object() || !f.contains(key) || !f[key].is_number()) return std::nullopt;
  return f[key].get<double>();
}

bool findRecordedTransform(const Session& session, const std::string& name, Eigen::Matrix4d& out) {
  // The session's typed calibrations and registrations: the latest step that succeeded with it.
  const auto entry = session.transform(name);
  if (!entry) return false;
  out = entry->matrix;
  return true;
}

Json statsJson(const std::vector<double>& values) {
  double sum = 0.0, sum2 = 0.0, mx = 0.0;
  for (double v : values) {
    sum += v;
    sum2 += v * v;
    mx = std::max(mx, std::abs(v));
  }
  const double n = values.empty() ? 1.0 : static_cast<double>(values.size());
  return Json{{"mean", sum / n}, {"rms", std::sqrt(sum2 / n)}, {"max", mx}, {"count", values.size()}};
}

}  // namespace detail
}  // namespace mrsns::workflow
