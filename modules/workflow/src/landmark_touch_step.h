#pragma once
// What the steps that acquire landmark touches with a tracked stylus share (the
// patient registration, the N-wire phantom's registration): the stylus's
// calibrated tip, the live recording's options from the step's parameters, and
// the names of what is still to touch.
#include <Eigen/Core>
#include <string>

#include "live_tracking_recording.h"
#include "registration_acquisition.h"
#include "step_internal.h"

namespace mrsns::workflow::detail {

/// The tip of `tool` in its marker's frame, from the session's pivot calibration (<Tool>TipTo<Tool>). Throws
/// InvalidArgumentError naming `step` and the pivot calibration to run first.
Eigen::Vector3d calibratedTip(const Session& session, const std::string& tool, const std::string& step);

/// The tip of `tool` as `pivot_step` (pivot-calibration, drill-calibration) found it, that step having succeeded:
/// never a copy another step keeps (a spin's tip frame) standing in for a pivot that failed since. Throws
/// InvalidArgumentError naming `step`, `pivot_step` and `why` (what the tip is needed for).
Eigen::Vector3d pivotTip(const Session& session, const std::string& tool, const std::string& pivot_step,
                         const std::string& step, const std::string& why);

/// A live touch acquisition's recording: the session's PlusServer (or the step's host/port), `duration_s`
/// (default_duration_s, at most 1800 s), `connect_timeout_s`, recorded into a new "<step>/<stem>.mhd" whose
/// name is returned in `recording`. Throws InvalidArgumentError for a `recording` parameter (that is
/// source=file) or values out of range.
LiveTrackingOptions touchRecordingOptions(const Session& session, const Params& p, const std::string& step,
                                          const std::string& stem, double default_duration_s, std::string& recording);

/// The labels of the targets no touch matched yet, comma-separated.
std::string untouchedLabels(const RegistrationAcquisition& a, const RegistrationTargets& t);

}  // namespace mrsns::workflow::detail
