// MainWindow's hologram stream (function area, MR): the session's models
// served to HMD clients over OpenIGTLink by tracking::HologramStreamer, on
// 127.0.0.1. One stream at a time: during live navigation the navigation
// loop serves it from its repository on every tracking batch (the tools'
// poses reach the HMD without waiting for the GUI thread); otherwise the
// window serves the models, updated from a GUI timer.
#include <QTimer>
#include <chrono>
#include <set>

#include "function_panel.h"
#include "live_navigation.h"
#include "main_window.h"
#include "message_presenter.h"
#include "mrsns/core/error.h"
#include "mrsns/core/transform_repository.h"
#include "mrsns/core/wall_clock.h"
#include "mrsns/igtlink/server.h"
#include "mrsns/tracking/hologram_client_preset.h"
#include "mrsns/tracking/hologram_streamer.h"

namespace mrsns::gui {
namespace {

/// OpenIGTLink device names are at most 20 characters and must be unique.
std::string deviceName(const std::string& scene_name, std::set<std::string>& used) {
  std::string base = scene_name.substr(scene_name.find(':') + 1);
  if (base.empty()) base = "Model";
  base = base.substr(0, 20);
  std::string name = base;
  for (int i = 2; used.count(name) != 0; ++i) {
    const std::string suffix = "_" + std::to_string(i);
    name = base.substr(0, 20 - suffix.size()) + suffix;
  }
  used.insert(name);
  return name;
}

}  // namespace

std::vector<tracking::HologramModel> MainWindow::hologramModels() const {
  std::vector<tracking::HologramModel> models;
  std::set<std::string> used;
  for (const auto& [name, mesh] : meshes_) {
    if (mesh.empty()) continue;
    models.push_back(tracking::HologramModel{deviceName(name, used), mesh, mesh.frame.empty() ? "Preop" : mesh.frame});
  }
  return models;
}

std::string MainWindow::hologramDeviceName(const std::string& scene_name) const {
  std::set<std::string> used;
  for (const auto& [name, mesh] : meshes_) {
    if (mesh.empty()) continue;
    std::string device = deviceName(name, used);
    if (name == scene_name) return device;
  }
  return {};
}

bool MainWindow::startHologramStream(int port, const std::string& client) {
  stopHologramStream();
  hologram_client_ = client;
  if (hologramModels().empty()) {
    function_->setStreaming(false, tr("off"));
    presenter_->present(UserMessage{MessageKind::Error, tr("Hologram stream"),
                                    tr("The session has no models to stream. Open a session with meshes or import "
                                       "one (Ctrl+M) first.")});
    return false;
  }
  if (navigating()) {
    try {
      hologram_port_ = live_->streamHolograms(hologramModels(), port, hologram_client_);
    } catch (const mrsns::Error& e) {
      function_->setStreaming(false, tr("off"));
      presenter_->present(
          UserMessage{MessageKind::Error, tr("Hologram stream"),
                      QString::fromStdString(e.what()) + tr("\nChoose another port if this one is in use.")});
      return false;
    }
    function_->setStreaming(true, tr("serving the live navigation on 127.0.0.1:%1 to %2, waiting for the HMD")
                                      .arg(hologram_port_)
                                      .arg(QString::fromStdString(hologram_client_)));
    return true;
  }
  if (!startWindowStream(port)) return false;
  // The bound port (port 0 picks one): navigation takes the stream over on it.
  hologram_port_ = stream_server_->port();
  return true;
}

bool MainWindow::startWindowStream(int port) {
  auto models = hologramModels();
  try {
    igtlink::ServerOptions options;
    options.bind_address = "127.0.0.1";
    options.port = static_cast<std::uint16_t>(port);
    auto server = std::make_unique<igtlink::Server>(options);
    auto repository = std::make_shared<TransformRepository>();
    auto streamer = std::make_unique<tracking::HologramStreamer>(
        *server, repository, std::move(models),
        tracking::withClientPreset({}, tracking::hologramClientPreset(hologram_client_)));
    server->start();
    stream_server_ = std::move(server);
    streamer_ = std::move(streamer);
  } catch (const mrsns::Error& e) {
    function_->setStreaming(false, tr("off"));
    presenter_->present(
        UserMessage{MessageKind::Error, tr("Hologram stream"),
                    QString::fromStdString(e.what()) + tr("\nChoose another port if this one is in use.")});
    return false;
  }
  auto* timer = new QTimer(this);
  timer->setObjectName(QStringLiteral("hologramTimer"));
  port = stream_server_->port();
  const QString client = QString::fromStdString(hologram_client_);
  connect(timer, &QTimer::timeout, this, [this, port, client] {
    if (!streamer_) return;
    streamer_->update(unixTimeSeconds());
    function_->setStreaming(
        true, tr("serving %1 %2 clients on 127.0.0.1:%3").arg(streamer_->readyClients()).arg(client).arg(port));
  });
  timer->start(33);
  function_->setStreaming(true, tr("serving on 127.0.0.1:%1 to %2, waiting for the HMD").arg(port).arg(client));
  return true;
}

void MainWindow::stopHologramStream() {
  hologram_port_ = 0;
  if (live_) live_->stopHologramStream();
  stopWindowStream();
}

void MainWindow::stopWindowStream() {
  if (auto* timer = findChild<QTimer*>(QStringLiteral("hologramTimer"))) {
    timer->stop();
    timer->deleteLater();
    timer->setObjectName(QString());
  }
  streamer_.reset();
  if (stream_server_) stream_server_->stop();
  stream_server_.reset();
  if (function_) function_->setStreaming(false, tr("off"));
}

}  // namespace mrsns::gui
