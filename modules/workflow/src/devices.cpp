// Tracker sources for the workflow: simulated scene, PlusServer, playback.
#include <cmath>

#include "mrsns/core/error.h"
#include "mrsns/tracking/igtl_source.h"
#include "mrsns/tracking/playback_source.h"
#include "mrsns/tracking/simulated_source.h"
#include "mrsns/workflow/navigation.h"

namespace mrsns::workflow {

std::vector<std::string> simulatedToolNames() {
  return {"PatientToTracker", "ProbeToTracker", "StylusToTracker", "FlangeToTracker"};
}

namespace {

// An operating-room layout seen from an optical tracker 1 m away: the
// patient's reference marker still, the probe sweeping 60 mm over the neck,
// the stylus pivoting, the robot flange circling above.
tracking::SimulatorOptions simulatedScene(const DeviceOptions& o) {
  tracking::SimulatorOptions sim;
  sim.seed = o.seed;
  sim.rate_hz = o.rate_hz;
  sim.noise.position_rms_mm = o.noise_mm;
  const auto names = simulatedToolNames();

  tracking::ToolScript patient;
  patient.name = names[0];
  Eigen::Isometry3d patient_pose = Eigen::Isometry3d::Identity();
  patient_pose.translation() = Eigen::Vector3d(0.0, 0.0, -1000.0);
  patient.motion = tracking::StaticMotion{patient_pose};

  tracking::ToolScript probe;
  probe.name = names[1];
  tracking::LinearSweep sweep;
  sweep.start.translation() = Eigen::Vector3d(-30.0, 40.0, -980.0);
  sweep.length_mm = 60.0;
  sweep.speed_mm_s = 20.0;
  probe.motion = sweep;
  probe.tremor = tracking::Tremor{};

  tracking::ToolScript stylus;
  stylus.name = names[2];
  stylus.motion = tracking::PivotMotion{};

  tracking::ToolScript flange;
  flange.name = names[3];
  tracking::CircularSweep circle;
  circle.centre_tracker = Eigen::Vector3d(0.0, 150.0, -900.0);
  circle.radius_mm = 20.0;
  circle.period_s = 8.0;
  flange.motion = circle;

  sim.tools = {patient, probe, stylus, flange};
  if (o.dropout_start_s >= 0.0 && o.dropout_duration_s > 0.0) {
    bool found = false;
    for (auto& tool : sim.tools) {
      if (tool.name == o.dropout_tool) {
        tool.dropouts.push_back(tracking::Dropout{o.dropout_start_s, o.dropout_duration_s});
        found = true;
      }
    }
    if (!found) {
      throw InvalidArgumentError("dropout tool '" + o.dropout_tool + "' is not a simulated tool (PatientToTracker, " +
                                 "ProbeToTracker, StylusToTracker, FlangeToTracker)");
    }
  }
  return sim;
}

}  // namespace

std::unique_ptr<tracking::TrackingSource> makeTrackingSource(const DeviceOptions& options,
                                                             std::shared_ptr<TransformRepository> repository) {
  if (options.source == "simulated") {
    return std::make_unique<tracking::SimulatedTrackingSource>(std::move(repository), simulatedScene(options));
  }
  if (options.source == "plus" || options.source == "openigtlink") {
    if (options.port <= 0 || options.port > 65535) {
      throw InvalidArgumentError("PlusServer port " + std::to_string(options.port) + " is not in 1..65535");
    }
    tracking::IgtlSourceOptions igtl;
    igtl.client.host = options.host;
    igtl.client.port = static_cast<std::uint16_t>(options.port);
    igtl.identify_device = true;
    return std::make_unique<tracking::IgtlTrackingSource>(std::move(repository), igtl);
  }
  if (options.source == "playback") {
    if (options.file.empty()) {
      throw InvalidArgumentError("playback needs a PLUS sequence file (parameter 'file')");
    }
    tracking::PlaybackOptions playback;
    playback.speed = options.playback_speed;
    return std::make_unique<tracking::PlaybackTrackingSource>(std::move(repository), options.file, playback);
  }
  throw InvalidArgumentError("unknown tracker source '" + options.source + "': use simulated, plus or playback");
}

}  // namespace mrsns::workflow
