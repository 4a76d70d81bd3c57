#pragma once
// The robot part of the navigation step: which robot and plan the loop uses (the session's first planned
// path once registration has run), and the figures of its safety supervisor.
#include <string>

#include "mrsns/workflow/navigation.h"
#include "step_internal.h"

namespace mrsns::workflow::detail {

/// The step parameters this part reads.
#define MRSNS_NAVIGATION_ROBOT_KEYS                                                                                 \
  "robot", "robot_path", "advance_speed_mm_s", "max_missed_cycles", "max_cycle_time_s", "silence_timeout_s", \
      "ur_host", "ur_rtde_port", "ur_script_port", "ur_dashboard_port", "ur_silence_s"

/// robot = "auto" (default: simulated when the session has planned paths, else none), "none", "simulated" or
/// "ur" (a UR controller at ur_host, ports ur_rtde_port, ur_script_port, ur_dashboard_port; needs the
/// session's robot calibration); robot_path: index into the registration's paths; silence_timeout_s: how old a
/// pose may be; max_missed_cycles and max_cycle_time_s: the supervisor's watchdog (a loaded workstation or a
/// phantom run without real time may need more than the defaults). Throws InvalidArgumentError for others.
void configureNavigationRobot(const Session& session, const Params& params, NavigationOptions& options);

/// Waits (up to 1 s, the arm's stopping limit with margin) for a stopping arm to come to rest, so the
/// figures carry its time-to-stop.
void waitForArmAtRest(const NavigationLoop& loop);

/// The supervisor's figures: state, stop reason, stop latency, time to stop, arm speed, transitions.
Json navigationRobotFigures(const NavigationOptions& options, const NavigationStatus& status,
                            const std::vector<NavigationRobotTransition>& transitions);

}  // namespace mrsns::workflow::detail
