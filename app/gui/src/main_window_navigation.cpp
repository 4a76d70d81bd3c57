// MainWindow's live navigation (function area): start and stop the
// navigation loop, record the run into the session as the navigation step.
#include <QStatusBar>
#include <filesystem>
#include <sstream>

#include "function_panel.h"
#include "live_navigation.h"
#include "main_window.h"
#include "mrsns/core/error.h"
#include "mrsns/workflow/navigation.h"
#include "mrsns/workflow/session.h"
#include "output_panel.h"

namespace mrsns::gui {

bool MainWindow::navigating() const {
  return live_ != nullptr && live_->running();
}

namespace {

/// The registration's planned paths (figures.paths), if any.
const nlohmann::json* plannedPaths(const nlohmann::json& state) {
  if (!state.contains("steps") || !state["steps"].contains("registration")) return nullptr;
  const auto& record = state["steps"]["registration"];
  if (!record.is_object() || record.value("status", "") != "ok" || !record.contains("figures")) return nullptr;
  const auto& figures = record["figures"];
  if (!figures.contains("paths") || !figures["paths"].is_array() || figures["paths"].empty()) return nullptr;
  return &figures["paths"];
}

}  // namespace

bool MainWindow::startNavigation() {
  workflow::NavigationOptions options;
  options.robot.robot = session_ && plannedPaths(session_->state()) ? "simulated" : "none";
  return startNavigation(options);
}

bool MainWindow::startNavigation(workflow::NavigationOptions options) {
  if (navigating()) return true;
  if (!session_) {
    function_->setLiveNavigation(false);
    presentError(tr("Start navigation"), tr("No session is open: navigation records every stream into one. Open a "
                                            "session (Ctrl+O) or the sample session (Ctrl+Shift+O) first."));
    return false;
  }
  if (refuseWhileBusy(tr("Start navigation"))) {
    function_->setLiveNavigation(false);
    return false;
  }
  LiveNavigationSetup setup;
  // The supervisor needs the patient and the probe; other sources may name
  // their tools differently (as the navigation step decides).
  if (options.devices.source != "simulated") options.required_transforms.clear();
  const auto ct_T_patient = ctFromPatient(session_->state());
  if (options.robot.robot == "simulated") {
    if (const auto* paths = plannedPaths(session_->state())) {
      // The robot follows the first planned path, placed by the registration.
      const auto& path = (*paths)[0];
      const auto& e = path["entry_ct"];
      const auto& t = path["target_ct"];
      if (e.is_array() && e.size() == 3 && t.is_array() && t.size() == 3) {
        options.robot.plan.name = path.value("name", "path 1");
        options.robot.plan.entry = Eigen::Vector3d(e[0].get<double>(), e[1].get<double>(), e[2].get<double>());
        options.robot.plan.target = Eigen::Vector3d(t[0].get<double>(), t[1].get<double>(), t[2].get<double>());
        if (ct_T_patient) options.robot.patient_T_plan = ct_T_patient->inverse();
      }
    }
  }
  setup.options = options;
  try {
    std::filesystem::create_directories(session_->resolve("navigation"));
    std::string name;
    for (int n = 1; name.empty() || std::filesystem::exists(session_->resolve(name)); ++n) {
      name = "navigation/live_" + std::to_string(n) + ".mhd";
    }
    setup.options.recording = session_->resolve(name);
    if (ct_T_patient) setup.world_T_patient = *ct_T_patient;
    // The tip's distance to what the drill must avoid: the vessel, else any soft tissue.
    for (const char* wanted : {"vessel", "tissue:"}) {
      for (const auto& [object, mesh] : meshes_) {
        if (setup.distance_target.empty() && object.rfind("tissue:", 0) == 0 &&
            object.find(wanted) != std::string::npos) {
          setup.distance_target = mesh;
          setup.distance_target_name = object.substr(7);
        }
      }
    }
    // One hologram stream: the window's hands its port to the loop, which
    // serves the same models with the live transforms.
    if (hologram_port_ != 0) {
      stopWindowStream();
      setup.options.stream_holograms = false;  // started below, once the loop runs
    }
    live_->start(setup);
    live_recording_ = name;
    if (hologram_port_ != 0) {
      try {
        live_->streamHolograms(hologramModels(), hologram_port_);
        function_->setStreaming(true, tr("serving the live navigation on 127.0.0.1:%1").arg(hologram_port_));
      } catch (const mrsns::Error& e) {
        hologram_port_ = 0;
        function_->setStreaming(false, tr("off"));
        presentError(tr("Hologram stream"),
                     QString::fromStdString(e.what()) + tr("\nNavigation runs without it; choose another port and "
                                                           "switch the stream on again."));
      }
    }
  } catch (const mrsns::Error& e) {
    function_->setLiveNavigation(false);
    presentError(tr("Cannot start navigation"), QString::fromStdString(e.what()));
    return false;
  } catch (const std::filesystem::filesystem_error& e) {
    function_->setLiveNavigation(false);
    presentError(tr("Cannot start navigation"),
                 tr("Cannot create the recording in the session folder: %1. Check its permissions and free space.")
                     .arg(QString::fromStdString(e.what())));
    return false;
  }
  function_->setLiveNavigation(true);
  preparation_->setBusy(true);
  function_->setBusy(true);
  setStepState(QStringLiteral("navigation"), StepState::Running, {});
  statusBar()->showMessage(tr("Live navigation: recording to %1").arg(QString::fromStdString(live_recording_)));
  return true;
}

void MainWindow::stopNavigation() {
  if (!navigating()) return;
  const nlohmann::json figures = live_->stop();
  function_->setLiveNavigation(false);
  // The stream goes on without the loop: the window serves the models again.
  if (hologram_port_ != 0 && !startWindowStream(hologram_port_)) hologram_port_ = 0;
  preparation_->setBusy(false);
  function_->setBusy(false);
  const bool ok = figures.value("batches", 0) > 0 && figures.value("recorder_error", std::string()).empty();
  std::ostringstream summary;
  summary.precision(3);
  summary << "live navigation " << figures.value("duration_s", 0.0) << " s: " << figures.value("batches", 0)
          << " tracking batches, " << figures.value("frames_recorded", 0) << " recorded";
  if (figures.value("robot_stopped", false)) summary << "; robot stopped (" << figures.value("stop_reason", "") << ")";
  if (figures.value("video_frames_recorded", 0) > 0) {
    summary << "; " << figures.value("video_frames_recorded", 0) << " ultrasound frames recorded";
  }
  const std::string stem = live_recording_.substr(0, live_recording_.size() - 4);
  nlohmann::json outputs = {live_recording_, stem + ".raw"};
  // The loop records the source's ultrasound frames beside the tracking (NavigationOptions::video_recording).
  if (figures.value("video_frames_recorded", 0) > 0) {
    outputs.push_back(stem + "_video.mhd");
    outputs.push_back(stem + "_video.raw");
  }
  try {
    session_->recordStep("navigation", {{"status", ok ? "ok" : "failed"},
                                        {"summary", summary.str()},
                                        {"figures", figures},
                                        {"outputs", outputs},
                                        {"params", {{"live", true}, {"source", figures.value("source", "")}}}});
  } catch (const mrsns::Error& e) {
    presentError(tr("Cannot record the navigation in the session"), QString::fromStdString(e.what()));
  }
  output_->showStepResult("navigation", ok ? "ok" : "failed", figures);
  setStepState(QStringLiteral("navigation"), ok ? StepState::Done : StepState::Failed, stepHeadline(figures));
  output_->setNavigationStatus(QString::fromStdString(summary.str()));
  statusBar()->showMessage(QString::fromStdString(summary.str()), 8000);
}

}  // namespace mrsns::gui
