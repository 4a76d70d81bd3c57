#pragma once
// The WebXR hologram client as one service beside the OpenIGTLink stream: its
// own hologram stream (tracking::HologramStreamer with the "slicer" preset,
// on a loopback port of its own, whatever preset the OpenIGTLink headsets
// use), the relay that turns it into the page's messages, and the HTTPS /
// WebSocket server. Feed update(), setPrompt() and updateMeshVertices() as
// the OpenIGTLink streamer is fed.
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include "mrsns/core/transform_repository.h"
#include "mrsns/tracking/hologram_streamer.h"
#include "mrsns/webxr/hologram_relay.h"
#include "mrsns/webxr/webxr_server.h"

namespace mrsns::webxr {

struct WebXrServiceOptions {
  /// Port, address, web_root, three_root, certificate and pairing code.
  WebXrServerOptions server;
  /// hologram_frame, forward_transforms, on_confirmation; the client preset
  /// is the page's own (header v2, millimetres, right-handed, meshes sent).
  tracking::HologramStreamOptions stream;
};

/// Debian's three.js (libjs-three): MRSNS_THREE_JS_DIR from the environment,
/// else /usr/share/javascript/three.
std::filesystem::path defaultThreeJsDirectory();

/// A workstation's WebXR options: the page in `web_root` (share/mrsns/webxr),
/// Debian's three.js, the certificate in `certificate_dir` (made on first use
/// for `bind_address`), a new pairing code. Throws as
/// ensureSelfSignedCertificate.
WebXrServiceOptions workstationWebXrOptions(
    const std::filesystem::path& web_root, const std::string& bind_address, std::uint16_t port,
    const std::filesystem::path& certificate_dir = defaultCertificateDirectory());

class WebXrHologramService {
 public:
  /// Throws as HologramStreamer and WebXrServer do.
  WebXrHologramService(std::shared_ptr<TransformRepository> repository, std::vector<tracking::HologramModel> models,
                       WebXrServiceOptions options);
  ~WebXrHologramService();
  WebXrHologramService(const WebXrHologramService&) = delete;
  WebXrHologramService& operator=(const WebXrHologramService&) = delete;

  /// Throws NetworkError when the port cannot be bound.
  void start();
  void stop();

  void update(double fallback_timestamp) noexcept { streamer_->update(fallback_timestamp); }
  void setPrompt(const std::string& text) { streamer_->setPrompt(text); }
  void updateMeshVertices(const std::string& model,
                          const Eigen::Matrix<double, Eigen::Dynamic, 3, Eigen::RowMajor>& vertices) {
    streamer_->updateMeshVertices(model, vertices);
  }

  [[nodiscard]] std::string url() const { return server_->url(); }
  [[nodiscard]] const std::string& pairingCode() const { return pairing_code_; }
  [[nodiscard]] const std::string& certificateFingerprint() const { return fingerprint_; }
  [[nodiscard]] WebXrServer& server() { return *server_; }
  /// After start().
  [[nodiscard]] HologramRelay& relay() { return *relay_; }
  [[nodiscard]] tracking::HologramStreamer& streamer() { return *streamer_; }

 private:
  std::string pairing_code_;
  std::string fingerprint_;
  std::unique_ptr<igtlink::Server> loopback_;
  std::unique_ptr<tracking::HologramStreamer> streamer_;
  std::unique_ptr<WebXrServer> server_;
  std::unique_ptr<HologramRelay> relay_;
};

}  // namespace mrsns::webxr
