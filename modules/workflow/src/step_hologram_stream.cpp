#include "step_hologram_stream.h"

#include "mrsns/core/log.h"
#include "mrsns/webxr/hologram_relay.h"
#include "mrsns/webxr/webxr_hologram_service.h"
#include "mrsns/webxr/webxr_server.h"
#include "mrsns/workflow/steps.h"

namespace mrsns::workflow::detail {

StepStreamAddress stepStreamAddress(const std::string& step, const Params& p, std::uint64_t max_body_bytes) {
  const int port = p.integer("hmd_port", 18945);
  if (port < 1 || port > 65535) throw InvalidArgumentError(step + ": hmd_port must be 1-65535");
  StepStreamAddress a;
  a.server.bind_address = p.text("hmd_address", "127.0.0.1");
  a.server.port = static_cast<std::uint16_t>(port);
  a.server.max_clients = 4;
  a.server.decode.max_body_size = max_body_bytes;
  a.endpoint = a.server.bind_address + ":" + std::to_string(port);
  a.unity = p.boolean("unity", false);
  a.webxr_port = p.integer("webxr_port", 0);
  if (a.webxr_port < 0 || a.webxr_port > 65535) throw InvalidArgumentError(step + ": webxr_port must be 1-65535");
  if (a.webxr_port > 0) {
    if (a.unity) {
      throw InvalidArgumentError(step +
                                 ": the WebXR page reads the stream in millimetres: set unity off with "
                                 "webxr_port");
    }
    a.webxr_address = p.text("webxr_address", a.server.bind_address);
    a.webxr_code = p.text("webxr_code", "");
    if (a.webxr_code.empty()) a.webxr_code = webxr::makePairingCode();
    if (!webxr::isValidPairingCode(a.webxr_code)) {
      throw InvalidArgumentError(step + ": webxr_code must be 6 to 12 digits");
    }
    a.webxr_tls_dir = p.text("webxr_tls_dir", webxr::defaultCertificateDirectory().string());
    a.endpoint += " or the WebXR page https://" + a.webxr_address + ":" + std::to_string(a.webxr_port) +
                  "/ (pairing code " + a.webxr_code + ")";
  }
  return a;
}

namespace {

tracking::HologramStreamOptions withConvention(tracking::HologramStreamOptions options, bool unity) {
  options.unity = unity;
  return options;
}

}  // namespace

StepHologramStream::StepHologramStream(const std::string& step, const StepStreamAddress& address,
                                       std::shared_ptr<TransformRepository> repository,
                                       std::vector<tracking::HologramModel> models,
                                       tracking::HologramStreamOptions options)
    : server_(address.server),
      streamer_(server_, std::move(repository), std::move(models), withConvention(std::move(options), address.unity)) {
  try {
    server_.start();
  } catch (const Error& e) {
    throw NetworkError(step + ": cannot serve the hologram stream on " + address.endpoint + " (" + e.what() +
                       "): another hologram stream (the GUI's, mrsns-cli serve) may hold that port; stop it or "
                       "choose hmd_port");
  }
  if (address.webxr_port == 0) return;
  try {
    auto web = webxr::workstationWebXrOptions(resourceDirectory() / "webxr", address.webxr_address,
                                              static_cast<std::uint16_t>(address.webxr_port), address.webxr_tls_dir);
    web.server.pairing_code = address.webxr_code;
    web_server_ = std::make_unique<webxr::WebXrServer>(std::move(web.server));
    // The page's relay is one more headset of this very stream (it connects while a page is paired).
    const std::string& bound = address.server.bind_address;
    const std::string stream_host = bound == "0.0.0.0" || bound == "::" ? "127.0.0.1" : bound;
    web_relay_ =
        std::make_unique<webxr::HologramRelay>(*web_server_, webxr::HologramRelayOptions{stream_host, server_.port()});
    web_server_->start();
    web_relay_->start();
  } catch (const Error& e) {
    server_.stop();
    throw NetworkError(step + ": cannot serve the WebXR page on " + address.webxr_address + ":" +
                       std::to_string(address.webxr_port) + " (" + e.what() +
                       "): the GUI's WebXR client or mrsns-cli serve may hold that port; stop it or choose webxr_port");
  }
  logger()->info("{}: hologram stream at {}", step, address.endpoint);
}

StepHologramStream::~StepHologramStream() {
  stop();
}

void StepHologramStream::stop() {
  if (web_relay_) web_relay_->stop();
  if (web_server_) web_server_->stop();
  server_.stop();
}

}  // namespace mrsns::workflow::detail
