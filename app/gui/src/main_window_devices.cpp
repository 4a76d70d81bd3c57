// The Devices menu: the simulated operating room (mrsns-sim as a child
// process) for demonstrations, and connecting to the tracker. Everything that
// comes from the simulated room is marked: the SIMULATED banner while it
// runs, and the connect-devices step records `simulated: true` from what the
// device says it is.
#include <QAction>
#include <QLabel>
#include <QMenu>
#include <QMenuBar>
#include <QStatusBar>

#include "main_window.h"
#include "mrsns/workflow/session.h"
#include "simulated_room.h"

namespace mrsns::gui {

void MainWindow::buildDevicesMenu() {
  sim_room_ = new SimulatedRoom(this);
  auto* devices = menuBar()->addMenu(tr("&Devices"));
  auto* start = devices->addAction(tr("Start &simulated operating room"));
  start->setObjectName(QStringLiteral("actionStartSimulatedRoom"));
  start->setToolTip(tr("Runs mrsns-sim (tracker, ultrasound and UR5 on their real protocols) for a demonstration"));
  connect(start, &QAction::triggered, this, [this] { startSimulatedRoom(); });
  auto* connect_action = devices->addAction(tr("&Connect to the tracker"));
  connect_action->setObjectName(QStringLiteral("actionConnectDevices"));
  connect_action->setShortcut(QKeySequence(QStringLiteral("Ctrl+D")));
  connect(connect_action, &QAction::triggered, this, [this] { connectDevices(); });
  auto* stop = devices->addAction(tr("S&top simulated operating room"));
  stop->setObjectName(QStringLiteral("actionStopSimulatedRoom"));
  connect(stop, &QAction::triggered, this, [this] { stopSimulatedRoom(); });

  connect(sim_room_, &SimulatedRoom::becameReady, this, [this](const SimulatedRoomEndpoints& e) {
    sim_label_->setText(tr("SIMULATED OR  PlusServer %1:%2%3")
                            .arg(e.host)
                            .arg(e.plus_port)
                            .arg(e.rtde_port ? tr("  UR RTDE %1").arg(e.rtde_port) : QString()));
    sim_label_->setToolTip(
        tr("Every measurement now comes from mrsns-sim, the simulated operating room; results "
           "from it are marked simulated"));
    sim_label_->show();
    statusBar()->showMessage(tr("Simulated operating room ready: Devices > Connect to the tracker"), 8000);
  });
  connect(sim_room_, &SimulatedRoom::failed, this, [this](const QString& why) {
    sim_label_->hide();
    presentError(tr("Simulated operating room"), why);
  });
  connect(sim_room_, &SimulatedRoom::stopped, this, [this] {
    sim_label_->hide();
    statusBar()->showMessage(tr("Simulated operating room stopped"), 5000);
  });
}

bool MainWindow::startSimulatedRoom(const QString& scenario) {
  QString why;
  const QString file = scenario.isEmpty() ? SimulatedRoom::defaultScenario() : scenario;
  if (!sim_room_->start(file, why)) {
    presentError(tr("Simulated operating room"), why);
    return false;
  }
  sim_label_->setText(tr("SIMULATED OR starting…"));
  sim_label_->show();
  return true;
}

void MainWindow::stopSimulatedRoom() {
  sim_room_->stop();
}

bool MainWindow::connectDevices() {
  nlohmann::json params{{"source", "plus"}, {"duration_s", 2.0}};
  if (sim_room_->ready()) {
    params["host"] = sim_room_->endpoints().host.toStdString();
    params["port"] = sim_room_->endpoints().plus_port;
  }
  return runStep(QStringLiteral("connect-devices"), params);
}

nlohmann::json MainWindow::deviceParams(const QString& step) const {
  // Once the session is connected to a PlusServer, the ultrasound calibrations acquire from it, as fCal does;
  // without one they run on the recordings they name (the bundled fCal data by default).
  nlohmann::json params = nlohmann::json::object();
  // The simulated room's UR controller is the one its tracker sees: the robot calibration drives it.
  if (session_ && step == QStringLiteral("robot-calibration") && sim_room_ != nullptr && sim_room_->ready() &&
      sim_room_->endpoints().rtde_port > 0) {
    const auto& e = sim_room_->endpoints();
    params = {{"source", "ur"},
              {"host", e.host.toStdString()},
              {"port", e.plus_port},
              {"ur_host", e.host.toStdString()},
              {"ur_rtde_port", e.rtde_port},
              {"ur_script_port", e.realtime_port},
              {"ur_dashboard_port", e.dashboard_port}};
    return params;
  }
  // The placement: the room's arm, navigated on its tracking (the session's calibrations of that arm and its
  // drill); connected to a PlusServer, its tracking with the UR controller the session's navigation names.
  if (session_ && step == QStringLiteral("robot-placement")) {
    if (sim_room_ != nullptr && sim_room_->ready() && sim_room_->endpoints().rtde_port > 0) {
      const auto& e = sim_room_->endpoints();
      return {{"source", "plus"},
              {"host", e.host.toStdString()},
              {"port", e.plus_port},
              {"robot", "ur"},
              {"ur_host", e.host.toStdString()},
              {"ur_rtde_port", e.rtde_port},
              {"ur_script_port", e.realtime_port},
              {"ur_dashboard_port", e.dashboard_port}};
    }
    const auto devices = session_->step("connect-devices");
    if (devices.is_object() && devices.value("status", "") == "ok" && devices.contains("params") &&
        devices["params"].value("source", "") == "plus") {
      params = {{"source", "plus"}, {"robot", "ur"}};
      for (const char* key : {"host", "port"}) {
        if (devices["params"].contains(key)) params[key] = devices["params"][key];
      }
    }
    return params;
  }
  // The HMD calibrations with the headset (the cube; the camera's photos of the board): the simulated room's
  // (told its port when the room started), or a real one on the usual hologram port once the session is
  // connected to a PlusServer.
  // The board's digitisation: its prompts also go to the room's headset, where its operator reads them.
  if (session_ && step == QStringLiteral("checkerboard-digitisation") && sim_room_ != nullptr && sim_room_->ready() &&
      sim_room_->endpoints().hmd_port > 0) {
    const auto& e = sim_room_->endpoints();
    return {{"host", e.host.toStdString()}, {"port", e.plus_port}, {"hmd_port", e.hmd_port}};
  }
  if (session_ && (step == QStringLiteral("hmd-calibration") || step == QStringLiteral("hmd-camera-calibration"))) {
    if (sim_room_ != nullptr && sim_room_->ready() && sim_room_->endpoints().hmd_port > 0) {
      const auto& e = sim_room_->endpoints();
      return {{"source", "hmd"}, {"host", e.host.toStdString()}, {"port", e.plus_port}, {"hmd_port", e.hmd_port}};
    }
    const auto devices = session_->step("connect-devices");
    if (devices.is_object() && devices.value("status", "") == "ok" && devices.contains("params") &&
        devices["params"].value("source", "") == "plus") {
      params["source"] = "hmd";
    }
    return params;
  }
  if (!session_ || (step != QStringLiteral("us-spatial-calibration") && step != QStringLiteral("us-temporal-calibration")))
    return params;
  const auto devices = session_->step("connect-devices");
  if (devices.is_object() && devices.value("status", "") == "ok" && devices.contains("params") &&
      devices["params"].value("source", "") == "plus") {
    params["source"] = "plus";
  }
  return params;
}

}  // namespace mrsns::gui
