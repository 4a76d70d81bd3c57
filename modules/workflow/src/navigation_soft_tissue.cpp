// The session's shape model, spatial and temporal calibrations and registration for the live soft tissue.
#include <Eigen/Geometry>
#include <nlohmann/json.hpp>
#include <optional>

#include "mrsns/workflow/navigation_soft_tissue.h"
#include "mrsns/workflow/session.h"
#include "patient_data.h"
#include "step_internal.h"

namespace mrsns::workflow {
namespace {
using Json = nlohmann::json;
}  // namespace

std::vector<std::string> applySessionSoftTissue(const Session& session, NavigationOptions& options) {
  std::vector<std::string> missing;
  const auto model = session.shapeModel();
  if (!model) missing.push_back("a soft-tissue shape model (shape-model step)");
  Eigen::Matrix4d probe_T_pixel, patient_T_ct;
  if (!detail::findRecordedTransform(session, "ImageToProbe", probe_T_pixel)) {
    missing.push_back("the probe's spatial calibration ImageToProbe (us-spatial-calibration step)");
  }
  if (!detail::findRecordedTransform(session, "CTToPatient", patient_T_ct)) {
    missing.push_back("the patient registration CTToPatient (registration step)");
  }
  if (!missing.empty()) return missing;
  auto& st = options.soft_tissue;
  st.shape_model = session.resolve(model->file);
  st.ct_T_model.matrix() = model->ct_T_model;
  if (const auto ct = session.ct(); ct && ct->size_px[0] > 0) st.ct_bounds = detail::ctBounds(*ct);
  st.patient_T_ct.matrix() = patient_T_ct;
  st.probe_T_pixel = probe_T_pixel;
  const Json calibration = session.step("us-spatial-calibration");
  if (calibration.is_object() && calibration.contains("figures") && calibration["figures"].contains("probe_tool") &&
      calibration["figures"]["probe_tool"].is_string()) {
    st.calibrated_probe = calibration["figures"]["probe_tool"].get<std::string>() + "ToTracker";
  }
  if (calibration.is_object() && calibration.contains("figures") && calibration["figures"].contains("image_size_px")) {
    const Json& size = calibration["figures"]["image_size_px"];
    if (size.is_array() && size.size() == 2 && size[0].is_number_integer() && size[1].is_number_integer()) {
      st.image_width = size[0].get<int>();
      st.image_height = size[1].get<int>();
    }
  }
  // The lag the spatial calibration was made with (its own estimate or the temporal calibration's).
  st.tracker_lag_s = 1e-3 * detail::recordedStepFigure(session, "us-spatial-calibration", "tracker_lag_ms")
                                .value_or(detail::recordedStepFigure(session, "us-temporal-calibration", "tracker_lag_ms")
                                              .value_or(0.0));
  return missing;
}

}  // namespace mrsns::workflow
