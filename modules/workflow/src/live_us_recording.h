#pragma once
// Records a tracked ultrasound sweep from a PlusServer (or mrsns-sim) into a
// PLUS sequence, as PLUS's fCal does: every IMAGE frame with each tool's
// transform interpolated at the frame's timestamp from the tracker samples
// around it (Invalid when the tool was not seen within 0.1 s on both sides).
#include <string>

#include "mrsns/core/tracked_frame.h"
#include "mrsns/workflow/steps.h"

namespace mrsns::workflow::detail {

struct LiveUsRecordingOptions {
  std::string host = "127.0.0.1";
  int port = 18944;
  double max_duration_s = 120.0;  ///< stop after this long at the latest
  double idle_stop_s = 2.0;       ///< stop when no frame came for this long after the first
  double connect_timeout_s = 10.0;
  std::size_t max_frames = 4000;  ///< the sweep is held in memory until it is written
};

struct LiveUsRecording {
  TrackedSequence sequence;
  /// The tracker's own samples, each at its own timestamp (PLUS's tracker buffer: 0x0 frames), every tool
  /// sampled at that instant in the frame: what a temporal calibration compares with the video.
  std::vector<TrackedFrame> tracker_frames;
  std::string device_identity;
  std::size_t frames_refused = 0;  ///< other size or format than the first frame
  std::size_t tool_samples = 0;
  double seconds = 0.0;
};

/// Throws NetworkError when nothing connects or no frame arrives within the
/// connect timeout (the message names host:port), Cancelled when cancelled.
LiveUsRecording recordLiveUltrasound(const LiveUsRecordingOptions& options, const StepContext& context);

}  // namespace mrsns::workflow::detail
