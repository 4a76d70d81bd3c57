// The simulated operating room as a child process of the GUI.
#include "simulated_room.h"

#include <QCoreApplication>
#include <QDir>
#include <QFile>
#include <QFileInfo>
#include <QJsonDocument>
#include <QJsonObject>
#include <QProcess>
#include <QTemporaryDir>
#include <QTimer>

#include "mrsns/core/error.h"
#include "mrsns/igtlink/server.h"
#include "mrsns/workflow/steps.h"

namespace mrsns::gui {

SimulatedRoom::SimulatedRoom(QObject* parent) : QObject(parent) {
  poll_ = new QTimer(this);
  poll_->setInterval(100);
  connect(poll_, &QTimer::timeout, this, &SimulatedRoom::pollReady);
}

SimulatedRoom::~SimulatedRoom() {
  // Destroyed with the main window: whoever listens to stopped() may already be half destroyed (a window
  // closed while the room runs crashed in its status bar), so the room ends without a word.
  blockSignals(true);
  stop();
}

QString SimulatedRoom::findProgram() {
  const QDir here(QCoreApplication::applicationDirPath());
  // Installed: /usr/bin/mrsns-sim beside /usr/bin/mrsns. Build tree: app/gui/mrsns and app/sim/mrsns-sim.
  for (const QString& candidate :
       {here.filePath(QStringLiteral("mrsns-sim")), here.filePath(QStringLiteral("../sim/mrsns-sim")),
        here.filePath(QStringLiteral("../../app/sim/mrsns-sim"))}) {
    const QFileInfo info(candidate);
    if (info.isFile() && info.isExecutable()) return info.canonicalFilePath();
  }
  return {};
}

QString SimulatedRoom::defaultScenario() {
  return QString::fromStdString((workflow::resourceDirectory() / "scenarios" / "default.json").string());
}

bool SimulatedRoom::start(const QString& scenario, QString& why) {
  if (running()) {
    why = tr("the simulated operating room is already running");
    return false;
  }
  const QString program = findProgram();
  if (program.isEmpty()) {
    why = tr("mrsns-sim was not found beside mrsns: build or install it (it is part of the MR-SNS package)");
    return false;
  }
  if (!QFileInfo::exists(scenario)) {
    why = tr("the scenario %1 does not exist").arg(scenario);
    return false;
  }
  dir_ = std::make_unique<QTemporaryDir>(QDir::temp().filePath(QStringLiteral("mrsns-sim-XXXXXX")));
  if (!dir_->isValid()) {
    why = tr("cannot make a temporary folder for the simulated operating room");
    return false;
  }
  ready_ = false;
  stopping_ = false;
  endpoints_ = {};
  process_ = new QProcess(this);
  process_->setProgram(program);
  QStringList arguments = {QStringLiteral("run"),      QStringLiteral("--scenario"), scenario,
                           QStringLiteral("--any-ports"), QStringLiteral("--duration"), QStringLiteral("0"),
                           QStringLiteral("--truth"),  truthFile(),                QStringLiteral("--ready-file"),
                           dir_->filePath(QStringLiteral("ready.json")), QStringLiteral("--json")};
  // A headset in the scenario is told a free port for the workstation's hologram stream, so a stream the lab
  // runs on the usual port (18945) for a real headset is never met by the simulated one.
  QFile scenario_file(scenario);
  if (scenario_file.open(QIODevice::ReadOnly)) {
    const QJsonObject hmd =
        QJsonDocument::fromJson(scenario_file.readAll()).object().value(QStringLiteral("hmd")).toObject();
    if (!hmd.isEmpty() && hmd.value(QStringLiteral("enabled")).toBool(true)) {
      try {
        arguments << QStringLiteral("--hmd-port") << QString::number(igtlink::freeLocalPort());
      } catch (const Error&) {
        // The scenario's own port, then.
      }
    }
  }
  process_->setArguments(arguments);
  connect(process_, QOverload<int, QProcess::ExitStatus>::of(&QProcess::finished), this,
          [this](int code, QProcess::ExitStatus) {
            poll_->stop();
            const QString err = QString::fromUtf8(process_->readAllStandardError()).trimmed();
            const bool expected = stopping_;
            ready_ = false;
            process_->deleteLater();
            process_ = nullptr;
            if (expected) {
              emit stopped();
            } else {
              emit failed(err.isEmpty() ? tr("mrsns-sim ended (exit code %1)").arg(code) : err.split('\n').last());
            }
          });
  process_->start();
  if (!process_->waitForStarted(5000)) {
    why = tr("mrsns-sim did not start: %1").arg(process_->errorString());
    process_->deleteLater();
    process_ = nullptr;
    return false;
  }
  poll_->start();
  return true;
}

void SimulatedRoom::pollReady() {
  QFile ready(dir_ ? dir_->filePath(QStringLiteral("ready.json")) : QString());
  if (!ready.exists() || !ready.open(QIODevice::ReadOnly)) return;
  const QJsonObject j = QJsonDocument::fromJson(ready.readAll()).object();
  poll_->stop();
  endpoints_.host = j.value(QStringLiteral("host")).toString();
  endpoints_.plus_port = j.value(QStringLiteral("plus_port")).toInt();
  const QJsonObject robot = j.value(QStringLiteral("robot")).toObject();
  endpoints_.rtde_port = robot.value(QStringLiteral("rtde")).toInt();
  endpoints_.dashboard_port = robot.value(QStringLiteral("dashboard")).toInt();
  endpoints_.realtime_port = robot.value(QStringLiteral("realtime")).toInt();
  endpoints_.hmd_port = j.value(QStringLiteral("hmd_port")).toInt();
  ready_ = true;
  emit becameReady(endpoints_);
}

void SimulatedRoom::stop() {
  if (process_ == nullptr) return;
  stopping_ = true;
  process_->terminate();
  if (!process_->waitForFinished(5000)) process_->kill();
}

bool SimulatedRoom::running() const {
  return process_ != nullptr;
}

QString SimulatedRoom::truthFile() const {
  return dir_ ? dir_->filePath(QStringLiteral("truth.json")) : QString();
}

}  // namespace mrsns::gui
