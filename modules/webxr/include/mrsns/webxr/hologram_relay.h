#pragma once
// The bridge between the hologram stream and the WebXR pages: an OpenIGTLink
// client of the workstation's own hologram server (tracking::HologramStreamer,
// default "slicer" preset: header v2, millimetres, right-handed) that turns
// what a headset would receive into the page's WebSocket messages
// (doc/webxr_client.md):
//
//   POLYDATA -> binary "mesh"      NDARRAY  -> binary "vertices"
//   TRANSFORM -> "transform"       STATUS   -> "status" (tracking lost / ok)
//   STRING "Prompt" -> "prompt"
//
// and the page's "confirm" back as the STRING "Confirm" the HMD calibrations
// take (the streamer's on_confirmation). It keeps the latest of each, so a
// page that pairs (or reconnects) later gets the whole scene at once. Being a
// client of the stream, it gets exactly what an OpenIGTLink headset gets and
// nothing more: no message from a page reaches anything but the stream's
// confirmation callback. It connects to the stream while at least one page is
// paired and leaves when the last one goes, so the stream's count of ready
// headsets (HologramStreamer::readyClients) counts paired pages.
//
// Latency: each "transform" carries the tracker sample's time (the message's
// header timestamp); the page echoes it in "shown" once the frame with that
// pose is drawn, and the relay measures sample -> displayed on the
// workstation's clock (so it includes the way back, an upper bound).
#include <cstdint>
#include <functional>
#include <memory>
#include <string>

#include "mrsns/webxr/webxr_server.h"

namespace mrsns::webxr {

struct HologramRelayOptions {
  std::string stream_host = "127.0.0.1";
  std::uint16_t stream_port = 18944;
};

struct HologramRelayStats {
  bool stream_connected = false;
  std::size_t models = 0;
  std::uint64_t transforms_relayed = 0;
  std::uint64_t confirmations_forwarded = 0;
  std::uint64_t display_reports = 0;
  std::size_t models_shown = 0;  ///< the scene's models some page reported drawing at a pose
  /// Tracker sample -> pose displayed by a page, ms (recent reports; NaN without any).
  double display_latency_p50_ms = 0.0;
  double display_latency_p99_ms = 0.0;
  double display_latency_max_ms = 0.0;
};

/// One page's report that it drew a model at a pose.
struct DisplayedPose {
  WebXrClientId client = 0;
  std::string model;
  double matrix[16] = {};    ///< row-major, mm, as the page's scene holds it
  double sample_time = 0.0;  ///< the tracker sample's time (s since 1970)
  double latency_ms = 0.0;   ///< sample -> this report's arrival
};

class HologramRelay {
 public:
  /// Installs the server's handlers: construct it before server.start().
  HologramRelay(WebXrServer& server, HologramRelayOptions options);
  ~HologramRelay();
  HologramRelay(const HologramRelay&) = delete;
  HologramRelay& operator=(const HologramRelay&) = delete;

  /// From now on, connects to the stream whenever a page is paired (and keeps reconnecting). Returns at once.
  void start();
  void stop();

  /// Called for each page's "shown" report (on the WebXR server's thread).
  void onDisplayed(std::function<void(const DisplayedPose&)> handler);

  [[nodiscard]] HologramRelayStats stats() const;

 private:
  struct Impl;
  std::shared_ptr<Impl> impl_;
};

}  // namespace mrsns::webxr
