#pragma once
// Records the tracking stream of a PlusServer (or mrsns-sim) into the session,
// crash-safe, while a guided acquisition runs (pivoting a stylus, touching
// landmarks): one frame per tracker timestamp with every tool's transform, as
// PLUS records a tracker buffer. A tool not in a frame gets its latest sample
// when that is at most 0.1 s older, else it is left out (Missing, as PLUS).
// The caller's monitor sees every frame recorded so far a few times a second,
// gives the operator feedback and says when the acquisition is complete.
#include <filesystem>
#include <functional>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "mrsns/core/tracked_frame.h"
#include "mrsns/workflow/session.h"
#include "mrsns/workflow/steps.h"

namespace mrsns::workflow::detail {

struct LiveTrackingOptions {
  std::string host = "127.0.0.1";
  int port = 18944;
  double max_duration_s = 60.0;    ///< stop after this long at the latest
  double connect_timeout_s = 10.0;  ///< no tracking at all for this long: the server is not there
  std::filesystem::path recording;  ///< .mhd (+ .raw): written as it arrives, synced every 0.5 s
};

struct LiveTrackingRecording {
  std::vector<TrackedFrame> frames;
  std::string device_identity;
  double seconds = 0.0;
  bool complete = false;  ///< the monitor said so (else the time ran out)
};

/// Returns true when the acquisition is complete; `message` is shown to the
/// operator (progress text). Called on the step's thread.
using LiveTrackingMonitor = std::function<bool(const std::vector<TrackedFrame>& frames, std::string& message)>;

/// True when the device that answered says it is mrsns-sim (its PlusServer, its frame grabber).
[[nodiscard]] inline bool fromSimulatedRoom(const std::string& device_identity) {
  return device_identity.rfind("mrsns-sim", 0) == 0;
}

/// A step's `recording` parameter: absolute as given, else relative to the session folder.
[[nodiscard]] inline std::filesystem::path recordingPath(const Session& session, const std::string& recording) {
  return std::filesystem::path(recording).is_absolute() ? std::filesystem::path(recording)
                                                        : session.resolve(recording);
}

/// figures.recorded of a live acquisition: the file, what it holds, how long, who sent it, from where.
[[nodiscard]] nlohmann::json recordedFigures(const LiveTrackingRecording& r, const std::string& file,
                                             const LiveTrackingOptions& options);

/// Throws NetworkError when no tracking arrives within the connect timeout
/// (the message names host:port), Cancelled when cancelled (the frames
/// recorded so far stay on disk), FileError when the recording cannot be
/// created.
LiveTrackingRecording recordLiveTracking(const LiveTrackingOptions& options, const LiveTrackingMonitor& monitor,
                                         const StepContext& context);

}  // namespace mrsns::workflow::detail
