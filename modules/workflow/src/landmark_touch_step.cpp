// Shared pieces of the landmark-touch steps (see landmark_touch_step.h).
#include "landmark_touch_step.h"

namespace mrsns::workflow::detail {

Eigen::Vector3d pivotTip(const Session& session, const std::string& tool, const std::string& pivot_step,
                         const std::string& step, const std::string& why) {
  const std::string name = tool + "TipTo" + tool;
  const auto pivot = session.step(pivot_step);
  const bool ok = pivot.is_object() && pivot.value("status", "") == "ok" && pivot.contains("figures") &&
                  pivot["figures"].contains("transforms") && pivot["figures"]["transforms"].contains(name);
  if (!ok) {
    throw InvalidArgumentError(step + ": the session has no " + name + " from " + pivot_step + ": run " +
                               pivot_step + " with tool=" + tool + " first (" + why + ")");
  }
  return matrixFromJson(pivot["figures"]["transforms"][name], "session.json steps." + pivot_step + " " + name)
      .block<3, 1>(0, 3);
}

Eigen::Vector3d calibratedTip(const Session& session, const std::string& tool, const std::string& step) {
  return pivotTip(session, tool, "pivot-calibration", step, "the tip is what touches the landmarks");
}

LiveTrackingOptions touchRecordingOptions(const Session& session, const Params& p, const std::string& step,
                                          const std::string& stem, double default_duration_s, std::string& recording) {
  if (p.has("recording")) throw InvalidArgumentError(step + ": recording is for source=file");
  LiveTrackingOptions live;
  sessionPlusServer(session, p, live.host, live.port);
  live.max_duration_s = p.number("duration_s", default_duration_s);
  live.connect_timeout_s = p.number("connect_timeout_s", live.connect_timeout_s);
  if (!(live.max_duration_s > 0.0 && live.max_duration_s <= 1800.0) || !(live.connect_timeout_s > 0.0)) {
    throw InvalidArgumentError(step + ": duration_s must be in (0, 1800] s, connect_timeout_s > 0");
  }
  recording = freeSessionName(session, step, stem, ".mhd");
  live.recording = session.resolve(recording);
  return live;
}

std::string untouchedLabels(const RegistrationAcquisition& a, const RegistrationTargets& t) {
  std::string out;
  for (std::size_t f = 0; f < a.capture_of_fiducial.size(); ++f) {
    if (a.capture_of_fiducial[f] < 0) out += (out.empty() ? "" : ", ") + t.labels[f];
  }
  return out;
}

}  // namespace mrsns::workflow::detail
