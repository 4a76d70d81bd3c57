// MainWindow's live navigation (function area): start and stop the
// navigation loop, record the run into the session as the navigation step.
#include <QStatusBar>
#include <filesystem>
#include <sstream>

#include "function_panel.h"
#include "live_navigation.h"
#include "main_window.h"
#include "mrsns/core/error.h"
#include "mrsns/core/log.h"
#include "mrsns/workflow/navigation.h"
#include "mrsns/workflow/navigation_soft_tissue.h"
#include "mrsns/workflow/session.h"
#include "output_panel.h"
#include "session_import.h"

namespace mrsns::gui {

bool MainWindow::navigating() const {
  return live_ != nullptr && live_->running();
}

bool MainWindow::startNavigation() {
  workflow::NavigationOptions options;
  options.robot.robot = session_ && !session_->plans().empty() ? "simulated" : "none";
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
  const auto ct_T_patient = ctFromPatient(*session_);
  if (options.robot.robot == "simulated") {
    const auto plans = session_->plans();
    if (!plans.empty()) {
      // The robot follows the first planned screw, placed by the registration.
      options.robot.plan.name = plans[0].name;
      options.robot.plan.entry = plans[0].entry;
      options.robot.plan.target = plans[0].target;
      if (ct_T_patient) options.robot.patient_T_plan = ct_T_patient->inverse();
    }
  }
  // The source's own ultrasound updates the soft tissue when the session has what places and explains it (the
  // simulated tracker has no ultrasound: its sweep is simulated in the GUI).
  std::vector<std::string> soft_tissue_missing;
  if (options.devices.source != "simulated" && options.soft_tissue.shape_model.empty()) {
    soft_tissue_missing = workflow::applySessionSoftTissue(*session_, options);
    if (const auto shape = session_->shapeModel(); shape && soft_tissue_missing.empty()) {
      if (const auto mean = session_->model(shape->mean_model)) {
        setup.soft_tissue_object = sceneName(*mean);
        // The headsets see the posterior too: the mean model's vertices moved in the hologram stream.
        options.soft_tissue.hologram_model = hologramDeviceName(setup.soft_tissue_object);
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
    // The tip's distance to what the drill must avoid: a vessel, else any soft tissue (by the models' roles).
    for (const auto role : {workflow::ModelRole::Vessel, workflow::ModelRole::SoftTissue}) {
      for (const auto& model : session_->models(role)) {
        const auto shown = meshes_.find(sceneName(model));
        if (setup.distance_target.empty() && shown != meshes_.end()) {
          setup.distance_target = shown->second;
          setup.distance_target_name = model.name;
        }
      }
    }
    // One hologram stream: the window's hands its port to the loop, which
    // serves the same models with the live transforms.
    if (hologram_port_ != 0) {
      stopWindowStream();
      setup.options.stream_holograms = false;  // started below, once the loop runs
    }
    if (webxr_on_) stopWindowWebXr();  // the loop serves the page on the same port, with the same code
    live_->start(setup);
    if (!soft_tissue_missing.empty() && session_->shapeModel()) {
      std::string text;
      for (const auto& m : soft_tissue_missing) text += (text.empty() ? "" : "; ") + m;
      logger()->warn("navigation without the live soft tissue: it needs {}", text);
    }
    live_recording_ = name;
    if (hologram_port_ != 0) {
      try {
        live_->streamHolograms(hologramModels(), hologram_port_, hologram_client_);
        function_->setStreaming(true, tr("serving the live navigation on 127.0.0.1:%1").arg(hologram_port_));
      } catch (const mrsns::Error& e) {
        hologram_port_ = 0;
        function_->setStreaming(false, tr("off"));
        presentError(tr("Hologram stream"),
                     QString::fromStdString(e.what()) + tr("\nNavigation runs without it; choose another port and "
                                                           "switch the stream on again."));
      }
    }
    if (webxr_on_ && !startLoopWebXr()) stopWebXr();  // navigation runs without it
  } catch (const mrsns::Error& e) {
    function_->setLiveNavigation(false);
    if (webxr_on_ && !web_ && !startWindowWebXr()) stopWebXr();
    presentError(tr("Cannot start navigation"), QString::fromStdString(e.what()));
    return false;
  } catch (const std::filesystem::filesystem_error& e) {
    function_->setLiveNavigation(false);
    if (webxr_on_ && !web_ && !startWindowWebXr()) stopWebXr();
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
  if (webxr_on_ && !web_ && !startWindowWebXr()) stopWebXr();
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
