#include "mrsns/webxr/webxr_hologram_service.h"

#include <cstdlib>

#include "mrsns/igtlink/server.h"
#include "mrsns/tracking/hologram_client_preset.h"

namespace mrsns::webxr {

std::filesystem::path defaultThreeJsDirectory() {
  if (const char* dir = std::getenv("MRSNS_THREE_JS_DIR"); dir != nullptr && *dir != '\0') return dir;
  return "/usr/share/javascript/three";
}

WebXrServiceOptions workstationWebXrOptions(const std::filesystem::path& web_root, const std::string& bind_address,
                                            std::uint16_t port, const std::filesystem::path& certificate_dir) {
  WebXrServiceOptions options;
  options.server.bind_address = bind_address;
  options.server.port = port;
  options.server.web_root = web_root;
  options.server.three_root = defaultThreeJsDirectory();
  options.server.certificate = ensureSelfSignedCertificate(certificate_dir, {bind_address});
  options.server.pairing_code = makePairingCode();
  return options;
}

WebXrHologramService::WebXrHologramService(std::shared_ptr<TransformRepository> repository,
                                           std::vector<tracking::HologramModel> models, WebXrServiceOptions options)
    : pairing_code_(options.server.pairing_code), fingerprint_(options.server.certificate.sha256_fingerprint) {
  igtlink::ServerOptions loopback;
  loopback.bind_address = "127.0.0.1";
  loopback.port = 0;
  loopback_ = std::make_unique<igtlink::Server>(loopback);
  auto stream = tracking::withClientPreset(std::move(options.stream), tracking::hologramClientPreset("slicer"));
  streamer_ = std::make_unique<tracking::HologramStreamer>(*loopback_, std::move(repository), std::move(models),
                                                           std::move(stream));
  server_ = std::make_unique<WebXrServer>(std::move(options.server));
}

WebXrHologramService::~WebXrHologramService() {
  stop();
}

void WebXrHologramService::start() {
  loopback_->start();
  // The relay installs the server's handlers, so it exists before the server listens.
  relay_ = std::make_unique<HologramRelay>(*server_, HologramRelayOptions{"127.0.0.1", loopback_->port()});
  server_->start();
  relay_->start();
}

void WebXrHologramService::stop() {
  if (relay_) relay_->stop();
  if (server_) server_->stop();
  if (loopback_) loopback_->stop();
}

}  // namespace mrsns::webxr
