#pragma once
// Shared pieces of the step implementations: parameter reading with
// unknown-key detection, cancellation, JSON helpers.
#include <Eigen/Geometry>
#include <initializer_list>
#include <optional>
#include <set>
#include <string>

#include "mrsns/core/error.h"
#include "mrsns/tracking/igtl_source.h"
#include "mrsns/workflow/steps.h"

namespace mrsns::workflow::detail {

using Json = nlohmann::json;

/// Reads a step's parameters; every key must be one the step knows, so a
/// misspelt parameter is an error rather than silently ignored.
class Params {
 public:
  Params(const std::string& step, const Json& params, std::initializer_list<const char*> known);
  [[nodiscard]] double number(const std::string& key, double fallback) const;
  [[nodiscard]] int integer(const std::string& key, int fallback) const;
  [[nodiscard]] bool boolean(const std::string& key, bool fallback) const;
  [[nodiscard]] std::string text(const std::string& key, const std::string& fallback) const;
  [[nodiscard]] bool has(const std::string& key) const { return params_.contains(key); }

 private:
  [[noreturn]] void wrongType(const std::string& key, const char* expected) const;
  std::string step_;
  Json params_;
};

/// Thrown inside a step when the user cancelled; runStep turns it into ok=false.
struct Cancelled {};

inline void checkCancel(const StepContext& context) {
  if (context.cancelled()) throw Cancelled{};
}

Json matrixJson(const Eigen::Matrix4d& m);
Eigen::Matrix4d matrixFromJson(const Json& j, const std::string& what);
/// The number `key` among the figures of `step`'s latest run when it succeeded (e.g. the temporal
/// calibration's tracker_lag_ms), if any.
std::optional<double> recordedStepFigure(const Session& session, const std::string& step, const std::string& key);
/// The transform `name` ("ImageToProbe") recorded by an earlier step, if any.
bool findRecordedTransform(const Session& session, const std::string& name, Eigen::Matrix4d& out);
/// The first "<folder>/<stem><ext>", "<folder>/<stem>_2<ext>", ... not yet in the session: a repeated
/// acquisition never overwrites an earlier one. Creates the folder.
std::string freeSessionName(const Session& session, const std::string& folder, const std::string& stem,
                            const std::string& ext);
/// host and port of the PlusServer the session's connect-devices step used (when it ran with source=plus),
/// overridden by the step's own host/port parameters.
void sessionPlusServer(const Session& session, const Params& p, std::string& host, int& port);
/// The options of a PlusServer client for a live acquisition (asking the device who it is); throws
/// InvalidArgumentError naming the port when it is not in 1..65535.
tracking::IgtlSourceOptions plusClientOptions(const std::string& host, int port);
/// RMS, mean, max of values.
Json statsJson(const std::vector<double>& values);

StepResult runImportCt(Session& session, const Json& params, const StepContext& context);
StepResult runImportLabelMap(Session& session, const Json& params, const StepContext& context);
StepResult runMakeModels(Session& session, const Json& params, const StepContext& context);
StepResult runImportModel(Session& session, const Json& params, const StepContext& context);
/// import-phantom: the cervical phantom's CT, segmentation and plan generated, then imported as a user's data.
StepResult runImportPhantom(Session& session, const Json& params, const StepContext& context);
StepResult runShapeModel(Session& session, const Json& params, const StepContext& context);
StepResult runFindFiducials(Session& session, const Json& params, const StepContext& context);
StepResult runPlaceFiducial(Session& session, const Json& params, const StepContext& context);
StepResult runPlanScrew(Session& session, const Json& params, const StepContext& context);
StepResult runImportPlan(Session& session, const Json& params, const StepContext& context);
StepResult runExportPlan(Session& session, const Json& params, const StepContext& context);
StepResult runConnectDevices(Session& session, const Json& params, const StepContext& context);
StepResult runPivotCalibration(Session& session, const Json& params, const StepContext& context);
StepResult runDrillCalibration(Session& session, const Json& params, const StepContext& context);
/// spin-calibration (the stylus) and drill-spin-calibration (the drill): the shaft from turning the tool about it.
StepResult runSpinCalibration(Session& session, const Json& params, const StepContext& context);
StepResult runDrillSpinCalibration(Session& session, const Json& params, const StepContext& context);
StepResult runUsPhantomRegistration(Session& session, const Json& params, const StepContext& context);
StepResult runUsSpatialCalibration(Session& session, const Json& params, const StepContext& context);
StepResult runUsTemporalCalibration(Session& session, const Json& params, const StepContext& context);
/// us-temporal-calibration with source=plus: the up/down motion over a flat target recorded live.
StepResult runLiveTemporalCalibration(Session& session, const Params& p, const StepContext& context);
StepResult runRobotCalibration(Session& session, const Json& params, const StepContext& context);
/// robot-calibration with source=ur: stations driven on a UR controller, seen by the session's tracker.
StepResult runLiveRobotCalibration(Session& session, const Json& params, const StepContext& context);
StepResult runRegistration(Session& session, const Json& params, const StepContext& context);
/// registration with source=plus (live from the tracker) or file (a recording of it).
StepResult runAcquiredRegistration(Session& session, const Json& params, const StepContext& context);
/// registration with source=simulated: the in-process simulated patient.
StepResult runSimulatedRegistration(Session& session, const Json& params, const StepContext& context);
StepResult runHmdCalibration(Session& session, const Json& params, const StepContext& context);
/// hmd-calibration with source=hmd (the cube held on its hologram in the headset) or file (its recording).
StepResult runAcquiredHmdCalibration(Session& session, const Json& params, const StepContext& context);
/// checkerboard-digitisation: the board's corners touched with the stylus (source=plus) or from their recording.
StepResult runCheckerboardDigitisation(Session& session, const Json& params, const StepContext& context);
/// hmd-camera-calibration: paper 000's checkerboard hand-eye calibration from the headset's photos (source=hmd)
/// or a data set on disk (source=file).
StepResult runHmdCameraCalibration(Session& session, const Json& params, const StepContext& context);
StepResult runNavigation(Session& session, const Json& params, const StepContext& context);
StepResult runRobotPlacement(Session& session, const Json& params, const StepContext& context);

}  // namespace mrsns::workflow::detail
