#pragma once
// The hologram stream a step serves to the headset itself (the HMD
// calibrations, the board's digitisation): its address from the step's
// parameters, started with a message that says what to do when the port is
// taken, stopped whatever leaves the step; and what the step says while it
// waits for the headset. With `webxr_port` the WebXR page (webxr::) relays the
// same stream to a headset browser: the cube, the prompts, the confirmations.
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "mrsns/core/format.h"
#include "mrsns/core/transform_repository.h"
#include "mrsns/igtlink/server.h"
#include "mrsns/tracking/hologram_streamer.h"
#include "step_internal.h"

namespace mrsns::webxr {
class WebXrServer;
class HologramRelay;
}  // namespace mrsns::webxr

namespace mrsns::workflow::detail {

/// Where a step serves the stream: `hmd_address` (127.0.0.1), `hmd_port` (18945), at most 4 clients, inbound
/// messages up to `max_body_bytes`, `unity` (false). Throws InvalidArgumentError naming `step` for a port outside
/// 1-65535; read before anything is served, so every parameter is refused first. With `webxr_port` (1-65535)
/// the WebXR client is served too, on `webxr_address` (default hmd_address) with `webxr_code` (default: a new
/// one; at least 6 digits) and the certificate in `webxr_tls_dir` (default webxr::defaultCertificateDirectory).
struct StepStreamAddress {
  igtlink::ServerOptions server;
  std::string endpoint;  ///< address:port, and the WebXR page with its code when served, for messages
  bool unity = false;
  int webxr_port = 0;  ///< 0: no WebXR client
  std::string webxr_address;
  std::string webxr_code;
  std::string webxr_tls_dir;
};
StepStreamAddress stepStreamAddress(const std::string& step, const Params& p, std::uint64_t max_body_bytes);

/// The server and its streamer, started; the server is stopped before the streamer goes (its handlers point at
/// it). Throws NetworkError naming `step` and the endpoint when the port cannot be served.
class StepHologramStream {
 public:
  StepHologramStream(const std::string& step, const StepStreamAddress& address,
                     std::shared_ptr<TransformRepository> repository, std::vector<tracking::HologramModel> models,
                     tracking::HologramStreamOptions options);
  ~StepHologramStream();
  StepHologramStream(const StepHologramStream&) = delete;
  StepHologramStream& operator=(const StepHologramStream&) = delete;

  [[nodiscard]] tracking::HologramStreamer& streamer() { return streamer_; }
  void stop();

 private:
  igtlink::Server server_;
  tracking::HologramStreamer streamer_;
  std::unique_ptr<webxr::WebXrServer> web_server_;
  std::unique_ptr<webxr::HologramRelay> web_relay_;
};

/// The failure once `waited_s` is past `wait_s`, else empty.
inline std::string headsetWaitFailure(int drops, const std::string& endpoint, double waited_s, double wait_s) {
  if (waited_s <= wait_s) return {};
  return (drops == 0 ? "no headset connected to the hologram stream at " + endpoint
                     : "the headset left and did not come back to " + endpoint) +
         " within " + formatFixed(wait_s, 0) + " s (is the HMD app running and pointed at this workstation?)";
}

/// The operator's progress line while waiting; `again` names what is asked again when it is back ("view 2 of 4").
inline std::string headsetWaitMessage(int drops, const std::string& endpoint, const std::string& again) {
  return drops == 0 ? "waiting for the headset to connect to the hologram stream at " + endpoint
                    : "the headset left: waiting for it to come back (" + again + " again)";
}

}  // namespace mrsns::workflow::detail
