#pragma once
// Records a tracked ultrasound sweep from a PlusServer (or mrsns-sim) into a
// PLUS sequence, as PLUS's fCal does: every IMAGE frame with each tool's
// transform interpolated at the frame's timestamp from the tracker samples
// around it (Invalid when the tool was not seen within 0.1 s on both sides).
#include <functional>
#include <string>

#include "mrsns/core/tracked_frame.h"
#include "mrsns/tracking/tracking_source.h"
#include "mrsns/workflow/steps.h"

namespace mrsns::workflow::detail {

struct LiveUsRecordingOptions {
  std::string host = "127.0.0.1";
  int port = 18944;
  double max_duration_s = 120.0;  ///< stop after this long at the latest
  double idle_stop_s = 2.0;       ///< stop when no frame came for this long after the first
  double connect_timeout_s = 10.0;
  std::size_t max_frames = 4000;  ///< the sweep is held in memory until it is written
  /// Given each frame as it arrives, in order (on the recording's thread, not the network's): returns true when
  /// the acquisition has what it needs (the recording then stops) and sets the progress shown. Unset: the
  /// recording stops on idle_stop_s, max_frames or max_duration_s only.
  std::function<bool(const tracking::TrackedImage& image, std::string& message)> on_frame;
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
  bool complete = false;  ///< on_frame said the acquisition had what it needs
};

/// Throws NetworkError when nothing connects or no frame arrives within the
/// connect timeout (the message names host:port), Cancelled when cancelled.
LiveUsRecording recordLiveUltrasound(const LiveUsRecordingOptions& options, const StepContext& context);

}  // namespace mrsns::workflow::detail
