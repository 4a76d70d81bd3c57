// MainWindow's WebXR client (function area, MR): a page the headset's browser
// opens (webxr::WebXrHologramService), admitted by the pairing code shown in
// the panel. One service at a time on one port with one code: the window's
// (the session's models, from a GUI timer), the navigation loop's while live
// navigation runs (tracked poses, soft-tissue vertices), or an HMD step's
// (the cube, the prompts; the page's confirmation confirms the step). A
// paired page reconnects by itself to whichever serves it.
#include <QTimer>

#include "function_panel.h"
#include "live_navigation.h"
#include "main_window.h"
#include "message_presenter.h"
#include "mrsns/core/error.h"
#include "mrsns/core/transform_repository.h"
#include "mrsns/core/wall_clock.h"
#include "mrsns/igtlink/server.h"
#include "mrsns/webxr/webxr_hologram_service.h"
#include "mrsns/workflow/steps.h"

namespace mrsns::gui {
namespace {

constexpr const char* kWebXrTimer = "webxrTimer";

}  // namespace

webxr::WebXrServiceOptions MainWindow::webXrOptions() {
  auto options = webxr::workstationWebXrOptions(workflow::resourceDirectory() / "webxr", webxr_address_,
                                                static_cast<std::uint16_t>(webxr_port_));
  options.server.pairing_code = webxr_code_;
  // The page's confirmation is the operator's, like the Confirm button and F8 (counted; a step takes the ones
  // made while it waits for one).
  std::atomic<std::uint64_t>* confirmations = &confirmations_;
  options.stream.on_confirmation = [confirmations](igtlink::ClientId, const std::string&) {
    confirmations->fetch_add(1);
  };
  return options;
}

bool MainWindow::startWebXr(int port, bool from_network) {
  stopWebXr();
  if (hologramModels().empty()) {
    function_->setWebXr(false, tr("off"));
    presenter_->present(UserMessage{MessageKind::Error, tr("WebXR client"),
                                    tr("The session has no models to show. Open a session with meshes or import "
                                       "one (Ctrl+M) first.")});
    return false;
  }
  webxr_address_ = from_network ? "0.0.0.0" : "127.0.0.1";
  webxr_port_ = port;
  webxr_code_ = webxr::makePairingCode();
  webxr_on_ = true;
  const bool ok = navigating() ? startLoopWebXr() : startWindowWebXr();
  if (!ok) stopWebXr();
  return ok;
}

bool MainWindow::startLoopWebXr() {
  try {
    auto& service = live_->serveWebXr(hologramModels(), webXrOptions());
    webxr_port_ = service.server().port();  // port 0 picks one; the same one from now on
  } catch (const mrsns::Error& e) {
    presenter_->present(
        UserMessage{MessageKind::Error, tr("WebXR client"),
                    QString::fromStdString(e.what()) + tr("\nChoose another port if this one is in use.")});
    return false;
  }
  showWebXrStatus(tr("live navigation"));
  return true;
}

bool MainWindow::startWindowWebXr() {
  try {
    auto repository = std::make_shared<TransformRepository>();
    auto service = std::make_unique<webxr::WebXrHologramService>(repository, hologramModels(), webXrOptions());
    service->start();
    webxr_port_ = service->server().port();  // port 0 picks one; the same one from now on
    web_ = std::move(service);
  } catch (const mrsns::Error& e) {
    presenter_->present(
        UserMessage{MessageKind::Error, tr("WebXR client"),
                    QString::fromStdString(e.what()) + tr("\nChoose another port if this one is in use.")});
    return false;
  }
  auto* timer = new QTimer(this);
  timer->setObjectName(QString::fromLatin1(kWebXrTimer));
  connect(timer, &QTimer::timeout, this, [this] {
    if (!web_) return;
    web_->update(unixTimeSeconds());
    showWebXrStatus(tr("the session's models"));
  });
  timer->start(100);
  showWebXrStatus(tr("the session's models"));
  return true;
}

void MainWindow::stopWindowWebXr() {
  if (auto* timer = findChild<QTimer*>(QString::fromLatin1(kWebXrTimer))) {
    timer->stop();
    timer->deleteLater();
    timer->setObjectName(QString());
  }
  if (web_) web_->stop();
  web_.reset();
}

void MainWindow::stopWebXr() {
  stopWindowWebXr();
  if (live_) live_->stopWebXr();
  webxr_on_ = false;
  if (function_) function_->setWebXr(false, tr("off"));
}

void MainWindow::showWebXrStatus(const QString& mode) {
  QString url = QStringLiteral("https://%1:%2/").arg(QString::fromStdString(webxr_address_)).arg(webxr_port_);
  QString detail = tr("Served by %1.").arg(mode);
  if (web_) {
    url = QString::fromStdString(web_->url());
    detail += tr(" %n headset(s) paired.", nullptr, static_cast<int>(web_->server().pairedClients()));
    // The operator compares it with what the headset's browser shows before accepting the certificate.
    detail += tr("\nCertificate SHA-256 %1").arg(QString::fromStdString(web_->certificateFingerprint()));
  }
  // One line: the panel is short; the rest in the tooltip.
  function_->setWebXr(true, tr("code <b>%1</b> at %2").arg(QString::fromStdString(webxr_code_), url));
  function_->setWebXrDetail(detail);
}

nlohmann::json MainWindow::withWebXr(const std::string& step, nlohmann::json params) {
  if (!webxr_on_ || navigating()) return params;
  if (step != "hmd-calibration" && step != "checkerboard-digitisation") return params;
  const std::string source = params.value("source", step == "hmd-calibration" ? "hmd" : "plus");
  if ((step == "hmd-calibration" && source != "hmd") || (step == "checkerboard-digitisation" && source != "plus")) {
    return params;
  }
  if (params.contains("webxr_port") || params.value("unity", false)) return params;
  // The step serves the page on the same port with the same code: the window's service makes way.
  stopWindowWebXr();
  params["webxr_port"] = webxr_port_;
  params["webxr_address"] = webxr_address_;
  params["webxr_code"] = webxr_code_;
  // The board's digitisation serves a stream only when asked (hmd_port): one of its own, off the GUI's.
  if (!params.contains("hmd_port") && step == "checkerboard-digitisation")
    params["hmd_port"] = igtlink::freeLocalPort();
  showWebXrStatus(tr("the %1 step").arg(QString::fromStdString(step)));
  return params;
}

}  // namespace mrsns::gui
