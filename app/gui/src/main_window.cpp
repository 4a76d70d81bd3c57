#include "main_window.h"
#include "area_dock.h"

#include <QAction>
#include <QApplication>
#include <QCloseEvent>
#include <QDateTime>
#include <QDir>
#include <QDockWidget>
#include <QFileDialog>
#include <QKeySequence>
#include <QLabel>
#include <QMenuBar>
#include <QProgressBar>
#include <QPushButton>
#include <QCoreApplication>
#include <QScrollArea>
#include <QSettings>
#include <QStandardPaths>
#include <QStatusBar>
#include <filesystem>

#include "display_area.h"
#include "function_panel.h"
#include "live_navigation.h"
#include "message_presenter.h"
#include "mrsns/core/error.h"
#include "mrsns/core/log.h"
#include "mrsns/igtlink/server.h"
#include "mrsns/rendering/scene.h"
#include "mrsns/rendering/slice_views.h"
#include "mrsns/tracking/hologram_streamer.h"
#include "mrsns/webxr/webxr_hologram_service.h"
#include "mrsns/workflow/planning.h"
#include "mrsns/workflow/session.h"
#include "mrsns/workflow/steps.h"
#include "output_panel.h"
#include "planning_panel.h"
#include "prep_dialogs.h"
#include "session_import.h"
#include "task_runner.h"

namespace mrsns::gui {
namespace {

constexpr int kMaxRecent = 8;
const char* kRecentKey = "sessions/recent";

QString toQ(const std::string& s) {
  return QString::fromStdString(s);
}
std::filesystem::path toPath(const QString& s) {
  return std::filesystem::path(s.toStdString());
}

}  // namespace

MainWindow::MainWindow(MainWindowOptions options, QWidget* parent) : QMainWindow(parent), options_(std::move(options)) {
  presenter_ = options_.presenter ? options_.presenter : std::make_shared<DialogPresenter>(this);
  setObjectName(QStringLiteral("mainWindow"));
  setWindowTitle(tr("MR-SNS"));
  setDockOptions(QMainWindow::AnimatedDocks | QMainWindow::AllowTabbedDocks);
  setStyleSheet(workstationStyleSheet());

  tasks_ = new TaskRunner(this);
  display_ = new DisplayArea(this);
  display_->setObjectName(QStringLiteral("displayArea"));
  setCentralWidget(display_);

  preparation_ = new PreparationPanel;
  function_ = new FunctionPanel;
  output_ = new OutputPanel;
  std::vector<StepEntry> steps;
  for (const auto& info : workflow::listSteps()) {
    steps.push_back(
        StepEntry{toQ(info.name), toQ(info.title), toQ(info.area), toQ(info.description), toQ(info.group)});
  }
  preparation_->setSteps(steps);
  function_->setSteps(steps);

  preparation_dock_ = makeAreaDock(this, tr("Preparation"), QStringLiteral("preparationArea"), preparation_, Qt::Vertical);
  function_dock_ = makeAreaDock(this, tr("Function"), QStringLiteral("functionArea"), function_, Qt::Horizontal);
  output_dock_ = makeAreaDock(this, tr("Output"), QStringLiteral("outputArea"), output_, Qt::Vertical);
  // Fig. 4: preparation left, output right, the function strip under display and output.
  setCorner(Qt::BottomLeftCorner, Qt::LeftDockWidgetArea);
  setCorner(Qt::BottomRightCorner, Qt::BottomDockWidgetArea);
  addDockWidget(Qt::LeftDockWidgetArea, preparation_dock_);
  addDockWidget(Qt::BottomDockWidgetArea, function_dock_);
  addDockWidget(Qt::RightDockWidgetArea, output_dock_);
  resizeDocks({preparation_dock_, output_dock_}, {350, 370}, Qt::Horizontal);

  connect(preparation_, &PreparationPanel::runStepRequested, this, &MainWindow::requestStep);
  connect(function_, &FunctionPanel::runStepRequested, this, &MainWindow::requestStep);
  connect(preparation_, &PreparationPanel::importRequested, this, &MainWindow::chooseAndImport);
  connect(preparation_, &PreparationPanel::pivotCalibrationRequested, this, &MainWindow::chooseAndRunPivot);
  connect(function_, &FunctionPanel::robotStopRequested, this, [this] {
    // During live navigation the loop owns the arm: it stops through the
    // supervisor while tracking, recording and the plots go on; Re-arm
    // lets it move again.
    if (navigating()) {
      if (live_->stopRobot(tr("Stop robot button"))) {
        statusBar()->showMessage(tr("Robot stopped by the operator: navigation goes on; Re-arm to continue"), 8000);
      } else {
        statusBar()->showMessage(tr("The robot's supervisor did not take the stop: end the navigation to stop it"));
      }
      return;
    }
    cancelTask();
  });
  live_ = new LiveNavigation(display_, output_, function_, this);
  connect(function_, &FunctionPanel::liveNavigationToggled, this, [this](bool on) {
    if (on) {
      startNavigation();
    } else {
      stopNavigation();
    }
  });
  connect(function_, &FunctionPanel::robotRearmRequested, live_, [this] { live_->rearm(); });
  connect(live_, &LiveNavigation::rearmRefused, this,
          [this](const QString& why) { statusBar()->showMessage(tr("Re-arm refused: %1").arg(why), 8000); });
  connect(live_, &LiveNavigation::robotStopped, this, [this](const QString& reason, const QDateTime& when) {
    // A status line, never a modal box: the surgeon keeps both hands free.
    statusBar()->showMessage(tr("Robot stopped at %1: %2").arg(when.toString(QStringLiteral("HH:mm:ss")), reason));
  });
  connect(function_, &FunctionPanel::resetCameraRequested, display_, &DisplayArea::resetCamera);
  connect(function_, &FunctionPanel::webXrToggled, this, [this](bool on) {
    if (on) {
      startWebXr(function_->webXrPort(), function_->webXrFromNetwork());
    } else {
      stopWebXr();
    }
  });
  connect(function_, &FunctionPanel::hologramStreamToggled, this, [this](bool on) {
    if (on) {
      startHologramStream(function_->streamPort(), function_->streamClient());
    } else {
      stopHologramStream();
    }
  });
  connect(function_, &FunctionPanel::layerToggled, this, [this](DisplayLayer layer, bool visible) {
    if (layer == DisplayLayer::SliceViews) {
      display_->setSliceViewsVisible(visible && display_->slices().hasVolume());
      return;
    }
    applyLayerVisibility(display_->scene(), layer, visible);
    display_->render();
  });

  buildPlanning();

  connect(tasks_, &TaskRunner::started, this, &MainWindow::onTaskStarted);
  connect(tasks_, &TaskRunner::progressed, this, &MainWindow::onTaskProgress);
  connect(tasks_, &TaskRunner::finished, this, &MainWindow::onTaskFinished);

  buildMenus();
  buildStatusBar();
  resize(1440, 900);
  if (options_.remember_window_state) restoreWindowState();
}

MainWindow::~MainWindow() {
  stopNavigation();
  tasks_->cancel();
  tasks_->waitForFinished();
  stopHologramStream();
  stopWebXr();
}

// ---------------------------------------------------------------- menus

void MainWindow::buildMenus() {
  auto* file = menuBar()->addMenu(tr("&Session"));
  auto add = [this](QMenu* menu, const QString& text, const QKeySequence& keys, const QString& name, auto slot) {
    auto* action = menu->addAction(text);
    action->setShortcut(keys);
    action->setObjectName(name);
    action->setShortcutContext(Qt::ApplicationShortcut);
    connect(action, &QAction::triggered, this, slot);
    return action;
  };
  add(file, tr("&New session…"), QKeySequence::New, QStringLiteral("actionNewSession"),
      [this] { chooseAndCreateSession(); });
  add(file, tr("&Open session…"), QKeySequence::Open, QStringLiteral("actionOpenSession"),
      [this] { chooseAndOpenSession(); });
  add(file, tr("Open &sample session"), QKeySequence(QStringLiteral("Ctrl+Shift+O")),
      QStringLiteral("actionOpenSample"), [this] { openSampleSession(); });
  recent_menu_ = file->addMenu(tr("&Recent sessions"));
  recent_menu_->setObjectName(QStringLiteral("menuRecent"));
  add(file, tr("&Save session"), QKeySequence::Save, QStringLiteral("actionSaveSession"), [this] { saveSession(); });
  add(file, tr("Save session &as…"), QKeySequence(QStringLiteral("Ctrl+Shift+S")),
      QStringLiteral("actionSaveSessionAs"), [this] { chooseAndSaveSessionAs(); });
  file->addSeparator();
  add(file, tr("Save screens&hot…"), QKeySequence(Qt::Key_F12), QStringLiteral("actionScreenshot"), [this] {
    const QString png =
        QFileDialog::getSaveFileName(this, tr("Save screenshot"), QStringLiteral("mrsns.png"), tr("PNG image (*.png)"));
    if (!png.isEmpty()) saveScreenshot(png);
  });
  file->addSeparator();
  add(file, tr("&Quit"), QKeySequence::Quit, QStringLiteral("actionQuit"), [this] { close(); });

  auto* data = menuBar()->addMenu(tr("&Data"));
  add(data, tr("Import &CT image…"), QKeySequence(QStringLiteral("Ctrl+I")), QStringLiteral("actionImportCt"),
      [this] { chooseAndImport(ImportKind::CtImage); });
  add(data, tr("Import &mesh…"), QKeySequence(QStringLiteral("Ctrl+M")), QStringLiteral("actionImportMesh"),
      [this] { chooseAndImport(ImportKind::Mesh); });
  add(data, tr("Import CT &DICOM folder…"), QKeySequence(QStringLiteral("Ctrl+Shift+I")),
      QStringLiteral("actionImportDicom"), [this] { chooseAndImportDicom(); });
  add(data, tr("Import la&bel map…"), QKeySequence(QStringLiteral("Ctrl+B")), QStringLiteral("actionImportLabels"),
      [this] { chooseAndImportLabelMap(); });
  add(data, tr("Make m&odels…"), QKeySequence(QStringLiteral("Ctrl+Shift+M")), QStringLiteral("actionMakeModels"),
      [this] { chooseAndMakeModels(); });
  add(data, tr("Import soft-tissue &shape model…"), QKeySequence(), QStringLiteral("actionImportShapeModel"),
      [this] { chooseAndImportShapeModel(); });
  add(data, tr("Import &landmarks as fiducials…"), QKeySequence(QStringLiteral("Ctrl+L")),
      QStringLiteral("actionImportLandmarks"), [this] { chooseAndImport(ImportKind::Landmarks); });
  add(data, tr("Phantom &patient data"), QKeySequence(), QStringLiteral("actionImportPhantom"),
      [this] { runStep(QStringLiteral("import-phantom")); });
  data->addSeparator();
  add(data, tr("&New screw"), QKeySequence(QStringLiteral("Ctrl+Shift+N")), QStringLiteral("actionNewScrew"),
      [this] { beginNewScrew(); });
  add(data, tr("Place &fiducial"), QKeySequence(QStringLiteral("Ctrl+Shift+F")), QStringLiteral("actionPlaceFiducial"),
      [this] { beginPlaceFiducial(); });
  add(data, tr("Import se&quence…"), QKeySequence(QStringLiteral("Ctrl+E")), QStringLiteral("actionImportSequence"),
      [this] { chooseAndImport(ImportKind::Sequence); });

  auto* steps = menuBar()->addMenu(tr("&Workflow"));
  int index = 0;
  for (const auto& info : workflow::listSteps()) {
    // Ctrl+1..9 run the steps in the order of the paper's workflow.
    const QKeySequence keys = index < 9 ? QKeySequence(QStringLiteral("Ctrl+%1").arg(index + 1)) : QKeySequence();
    const QString name = toQ(info.name);
    add(steps, toQ(info.title), keys, QStringLiteral("actionStep_") + name, [this, name] { requestStep(name); });
    ++index;
  }
  steps->addSeparator();
  add(steps, tr("Pivot calibration…"), QKeySequence(QStringLiteral("Ctrl+P")), QStringLiteral("actionPivot"),
      [this] { chooseAndRunPivot(); });
  add(steps, tr("&Cancel running task"), QKeySequence(Qt::Key_Escape), QStringLiteral("actionCancel"), [this] {
    if (placing_ != Placing::None) {
      cancelPlacing();
      return;
    }
    cancelTask();
  });
  // What the operator confirms during a step (the HMD calibration's holds): a foot pedal is a key to the
  // workstation; F8 by default, as pedals ship configured to send a function key.
  add(steps, tr("C&onfirm (foot pedal)"), QKeySequence(Qt::Key_F8), QStringLiteral("actionConfirm"),
      [this] { confirmStep(); });

  buildDevicesMenu();

  auto* view = menuBar()->addMenu(tr("&View"));
  add(view, tr("&Reset camera"), QKeySequence(Qt::Key_Home), QStringLiteral("actionResetCamera"),
      [this] { display_->resetCamera(); });
  view->addSeparator();
  for (auto* dock : {preparation_dock_, planning_dock_, function_dock_, output_dock_}) {
    view->addAction(dock->toggleViewAction());
  }
  planning_dock_->toggleViewAction()->setShortcut(QKeySequence(QStringLiteral("Alt+4")));
  preparation_dock_->toggleViewAction()->setShortcut(QKeySequence(QStringLiteral("Alt+1")));
  function_dock_->toggleViewAction()->setShortcut(QKeySequence(QStringLiteral("Alt+2")));
  output_dock_->toggleViewAction()->setShortcut(QKeySequence(QStringLiteral("Alt+3")));
  add(view, tr("&Full screen"), QKeySequence(Qt::Key_F11), QStringLiteral("actionFullScreen"),
      [this] { setWindowState(windowState() ^ Qt::WindowFullScreen); });

  auto* help = menuBar()->addMenu(tr("&Help"));
  add(help, tr("&Keyboard shortcuts"), QKeySequence(Qt::Key_F1), QStringLiteral("actionShortcuts"),
      [this] { showShortcuts(); });
  refreshRecentMenu();
}

void MainWindow::buildStatusBar() {
  session_status_ = new QLabel(tr("no session"), this);
  session_status_->setObjectName(QStringLiteral("sessionStatus"));
  task_label_ = new QLabel(this);
  task_label_->setObjectName(QStringLiteral("taskLabel"));
  progress_ = new QProgressBar(this);
  progress_->setObjectName(QStringLiteral("taskProgress"));
  progress_->setRange(0, 1000);
  progress_->setMaximumWidth(260);
  progress_->setTextVisible(false);
  progress_->hide();
  cancel_ = new QPushButton(tr("Cancel"), this);
  cancel_->setObjectName(QStringLiteral("taskCancel"));
  cancel_->setToolTip(tr("Cancel the running task (Esc)"));
  cancel_->hide();
  connect(cancel_, &QPushButton::clicked, this, &MainWindow::cancelTask);
  confirm_ = new QPushButton(tr("Confirm"), this);
  confirm_->setObjectName(QStringLiteral("taskConfirm"));
  confirm_->setToolTip(tr("Confirm what the step asks (F8, or the foot pedal): e.g. the cube held on its hologram"));
  confirm_->hide();
  connect(confirm_, &QPushButton::clicked, this, &MainWindow::confirmStep);
  statusBar()->addWidget(session_status_, 1);
  sim_label_ = new QLabel(this);
  sim_label_->setObjectName(QStringLiteral("simulatedBanner"));
  sim_label_->setStyleSheet(QStringLiteral("QLabel { background: #b35900; color: white; font-weight: bold; "
                                           "padding: 1px 6px; }"));
  sim_label_->hide();
  statusBar()->addPermanentWidget(sim_label_);
  statusBar()->addPermanentWidget(task_label_);
  statusBar()->addPermanentWidget(progress_);
  statusBar()->addPermanentWidget(confirm_);
  statusBar()->addPermanentWidget(cancel_);
}

void MainWindow::showShortcuts() {
  QString text;
  for (auto* action : findChildren<QAction*>()) {
    if (action->shortcut().isEmpty()) continue;
    text += QStringLiteral("%1\t%2\n")
                .arg(action->shortcut().toString(QKeySequence::NativeText), action->text().remove(QLatin1Char('&')));
  }
  presentInfo(tr("Keyboard shortcuts"), text);
}

// ---------------------------------------------------------------- settings

void MainWindow::restoreWindowState() {
  QSettings settings;
  restoreGeometry(settings.value(QStringLiteral("window/geometry")).toByteArray());
  restoreState(settings.value(QStringLiteral("window/state")).toByteArray());
}

void MainWindow::closeEvent(QCloseEvent* event) {
  stopNavigation();
  if (tasks_->busy()) {
    tasks_->cancel();
    tasks_->waitForFinished();
  }
  stopHologramStream();
  stopSimulatedRoom();
  if (options_.remember_window_state) {
    QSettings settings;
    settings.setValue(QStringLiteral("window/geometry"), saveGeometry());
    settings.setValue(QStringLiteral("window/state"), saveState());
  }
  event->accept();
}

QStringList MainWindow::recentSessions() const {
  if (!options_.remember_window_state) return {};
  return QSettings().value(QLatin1String(kRecentKey)).toStringList();
}

void MainWindow::rememberSession(const QString& folder) {
  if (!options_.remember_window_state) return;
  QSettings settings;
  QStringList recent = settings.value(QLatin1String(kRecentKey)).toStringList();
  const QString canonical = QDir(folder).absolutePath();
  recent.removeAll(canonical);
  recent.prepend(canonical);
  while (recent.size() > kMaxRecent) recent.removeLast();
  settings.setValue(QLatin1String(kRecentKey), recent);
  refreshRecentMenu();
}

void MainWindow::refreshRecentMenu() {
  recent_menu_->clear();
  const QStringList recent = recentSessions();
  for (int i = 0; i < recent.size(); ++i) {
    auto* action = recent_menu_->addAction(QStringLiteral("&%1  %2").arg(i + 1).arg(recent[i]));
    connect(action, &QAction::triggered, this, [this, folder = recent[i]] { openSession(folder); });
  }
  recent_menu_->setEnabled(!recent.isEmpty());
}

// ---------------------------------------------------------------- messages

void MainWindow::presentError(const QString& title, const QString& text) {
  logger()->warn("{}: {}", title.toStdString(), text.toStdString());
  presenter_->present(UserMessage{MessageKind::Error, title, text});
}

void MainWindow::presentInfo(const QString& title, const QString& text) {
  presenter_->present(UserMessage{MessageKind::Information, title, text});
}

bool MainWindow::refuseWhileBusy(const QString& what) {
  if (navigating()) {
    presentError(what, tr("Live navigation is running. Stop it first (Stop live navigation in the function area)."));
    return true;
  }
  if (!tasks_->busy()) return false;
  presentError(
      what,
      tr("\"%1\" is still running. Wait for it to finish or press Cancel (Esc) first.").arg(tasks_->currentTask()));
  return true;
}

// ---------------------------------------------------------------- tasks

bool MainWindow::taskRunning() const {
  return tasks_->busy();
}

void MainWindow::cancelTask() {
  if (!tasks_->busy()) return;
  tasks_->cancel();
  task_label_->setText(tr("cancelling %1…").arg(tasks_->currentTask()));
}

bool MainWindow::runStep(const QString& step, const nlohmann::json& params) {
  if (!session_) {
    presentError(tr("Run %1").arg(step), tr("No session is open. Open one (Ctrl+O) or the sample session "
                                            "(Ctrl+Shift+O) first."));
    return false;
  }
  if (refuseWhileBusy(tr("Run %1").arg(step))) return false;
  workflow::Session* session = session_.get();
  const std::string name = step.toStdString();
  confirm_->setVisible(name == "hmd-calibration");
  const std::atomic<std::uint64_t>* confirmations = &confirmations_;
  const nlohmann::json step_params = withWebXr(name, params);
  const bool started = tasks_->start(step, [session, name, params = step_params, confirmations](const TaskControl& control) {
    workflow::StepContext context;
    context.progress = control.progress;
    context.cancel = control.cancel;
    context.confirmations = confirmations;
    const workflow::StepResult result = workflow::runStep(*session, name, params, context);
    TaskOutcome outcome;
    outcome.ok = result.ok;
    outcome.cancelled = result.cancelled;
    outcome.summary = QString::fromStdString(result.summary);
    outcome.figures = result.figures;
    outcome.outputs = result.outputs;
    return outcome;
  });
  if (!started && webxr_on_ && !web_ && !navigating() && !startWindowWebXr()) stopWebXr();
  return started;
}

void MainWindow::confirmStep() {
  // Counted whether or not a step waits: the step takes only confirmations made while it waits for one.
  confirmations_.fetch_add(1);
  if (tasks_->busy()) task_label_->setText(tr("%1: confirmed").arg(tasks_->currentTask()));
}

bool MainWindow::importFile(ImportKind kind, const QString& path) {
  if (!session_) {
    presentError(tr("Import"), tr("No session is open. Open or create a session first: imported files are "
                                  "copied into it."));
    return false;
  }
  if (refuseWhileBusy(tr("Import"))) return false;
  // The patient's data go through their workflow steps, as `mrsns-cli session run` does.
  switch (kind) {
    case ImportKind::CtImage: {
      const auto params = ctImportParams({{"path", path.toStdString()}});
      return params && runStep(QStringLiteral("import-ct"), *params);
    }
    case ImportKind::Mesh: return runStep(QStringLiteral("import-model"), {{"path", path.toStdString()}});
    case ImportKind::Landmarks:
      return runStep(QStringLiteral("find-fiducials"), {{"source", "file"}, {"path", path.toStdString()}});
    case ImportKind::Sequence: break;
  }
  const auto folder = session_->folder();
  const auto file = toPath(path);
  return tasks_->start(
      QString::fromStdString(importRecordName(kind)),
      [kind, folder, file](const TaskControl& control) { return importIntoSession(kind, file, folder, control); });
}

bool MainWindow::runPivotCalibration(const QString& recording) {
  // The session's step on a file: recorded in the session as the live acquisition is.
  return runStep(QStringLiteral("pivot-calibration"),
                 nlohmann::json{{"source", "file"}, {"recording", toPath(recording).string()}});
}

void MainWindow::onTaskStarted(const QString& name) {
  preparation_->setBusy(true);
  planning_->setBusy(true);
  function_->setBusy(true);
  progress_->setValue(0);
  progress_->show();
  cancel_->show();
  task_label_->setText(tr("%1…").arg(name));
  setStepState(name, StepState::Running, {});
}

void MainWindow::onTaskProgress(const QString& name, double fraction, const QString& message) {
  progress_->setValue(static_cast<int>(std::clamp(fraction, 0.0, 1.0) * 1000));
  task_label_->setText(message.isEmpty() ? name : QStringLiteral("%1: %2").arg(name, message));
}

void MainWindow::onTaskFinished(const QString& name, const TaskOutcome& outcome) {
  preparation_->setBusy(false);
  planning_->setBusy(false);
  function_->setBusy(false);
  progress_->hide();
  cancel_->hide();
  confirm_->hide();
  task_label_->clear();
  const std::string step = name.toStdString();
  // An HMD step served the WebXR page; the window serves it again.
  if (webxr_on_ && !web_ && !navigating() && !startWindowWebXr()) stopWebXr();
  if (outcome.cancelled) {
    setStepState(name, StepState::Cancelled, {});
    statusBar()->showMessage(tr("%1 cancelled").arg(name), 5000);
  } else if (!outcome.error.isEmpty()) {
    setStepState(name, StepState::Failed, {});
    presentError(tr("%1 failed").arg(name), outcome.error);
  } else if (!outcome.ok) {
    setStepState(name, StepState::Failed, outcome.summary);
    output_->showStepResult(step, "failed", outcome.figures);
    presentError(tr("%1 did not succeed").arg(name), outcome.summary);
  } else {
    setStepState(name, StepState::Done, stepHeadline(outcome.figures));
    output_->showStepResult(step, "ok", outcome.figures);
    statusBar()->showMessage(outcome.summary, 8000);
    // Steps and imports change the session's data: show what it holds now.
    if (session_ && name != QLatin1String("pivot-calibration")) {
      try {
        if (name == QLatin1String("import-sequence")) recordImport(step, outcome);
        *session_ = workflow::Session::open(session_->folder());
      } catch (const mrsns::Error& e) {
        presentError(tr("Cannot reload the session"), QString::fromStdString(e.what()));
      }
      populateScene();
    }
  }
  emit taskFinished(name, outcome.ok && outcome.error.isEmpty());
}

void MainWindow::recordImport(const std::string& record, const TaskOutcome& outcome) {
  // Every import of a kind stays listed: the scene shows them all.
  nlohmann::json previous = session_->step(record);
  nlohmann::json outputs = previous.is_object() && previous.contains("outputs") && previous["outputs"].is_array()
                               ? previous["outputs"]
                               : nlohmann::json::array();
  for (const auto& output : outcome.outputs) {
    if (std::find(outputs.begin(), outputs.end(), output) == outputs.end()) outputs.push_back(output);
  }
  session_->recordStep(record, {{"status", "ok"},
                                {"summary", outcome.summary.toStdString()},
                                {"figures", outcome.figures},
                                {"outputs", outputs}});
}

void MainWindow::setStepState(const QString& step, StepState state, const QString& detail) {
  preparation_->setStepState(step, state, detail);
  function_->setStepState(step, state, detail);
}

// ---------------------------------------------------------------- choosers

void MainWindow::chooseAndOpenSession() {
  const QString folder = QFileDialog::getExistingDirectory(this, tr("Open session folder"));
  if (!folder.isEmpty()) openSession(folder);
}

void MainWindow::chooseAndCreateSession() {
  const QString folder = QFileDialog::getExistingDirectory(this, tr("New session: choose an empty folder"));
  if (!folder.isEmpty()) createSession(folder);
}

void MainWindow::chooseAndSaveSessionAs() {
  const QString folder = QFileDialog::getExistingDirectory(this, tr("Save session as: choose an empty folder"));
  if (!folder.isEmpty()) saveSessionAs(folder);
}

void MainWindow::chooseAndImport(ImportKind kind) {
  const QString path = QFileDialog::getOpenFileName(this, tr("Import"), QString(), importFileFilter(kind));
  if (path.isEmpty()) return;
  if (kind == ImportKind::Mesh) {
    if (!session_) {
      importFile(kind, path);  // says that a session is needed
      return;
    }
    if (const auto params = askModelImport(this, path)) runStep(QStringLiteral("import-model"), *params);
    return;
  }
  importFile(kind, path);
}

void MainWindow::requestStep(const QString& step) {
  // The steps that need the user's file or points ask for them first.
  if (step == QLatin1String("import-ct")) return chooseAndImport(ImportKind::CtImage);
  if (step == QLatin1String("import-label-map")) return chooseAndImportLabelMap();
  if (step == QLatin1String("make-models")) return chooseAndMakeModels();
  if (step == QLatin1String("import-model")) return chooseAndImport(ImportKind::Mesh);
  if (step == QLatin1String("shape-model")) return chooseAndImportShapeModel();
  if (step == QLatin1String("place-fiducial")) {
    beginPlaceFiducial();
    return;
  }
  if (step == QLatin1String("plan-screw")) {
    beginNewScrew();
    return;
  }
  if (step == QLatin1String("import-plan")) {
    const QString path = QFileDialog::getOpenFileName(this, tr("Import plan"), QString(),
                                                      tr("3D Slicer markups (*.mrk.json *.json);;All files (*)"));
    if (!path.isEmpty()) runStep(step, {{"path", path.toStdString()}});
    return;
  }
  if (step == QLatin1String("export-plan")) {
    const QString path = QFileDialog::getSaveFileName(this, tr("Export plan"), QStringLiteral("Plan.mrk.json"),
                                                      tr("3D Slicer markups (*.mrk.json)"));
    if (!path.isEmpty()) runStep(step, {{"path", path.toStdString()}});
    return;
  }
  runStep(step, deviceParams(step));
}

void MainWindow::chooseAndImportDicom() {
  const QString folder = QFileDialog::getExistingDirectory(this, tr("Import CT: DICOM series folder"));
  if (folder.isEmpty()) return;
  try {
    if (const auto series = askDicomSeries(this, folder)) {
      if (const auto params = ctImportParams(*series)) runStep(QStringLiteral("import-ct"), *params);
    }
  } catch (const mrsns::Error& e) {
    presentError(tr("Import CT"), QString::fromStdString(e.what()));
  }
}

std::optional<nlohmann::json> MainWindow::ctImportParams(nlohmann::json params) {
  if (!session_ || !session_->ct()) return params;
  const QString current = QString::fromStdString(session_->ct()->name);
  const bool yes = presenter_->confirm(
      {MessageKind::Warning, tr("Import CT"),
       tr("The session already has a CT (%1). Replace it?\n\nIts label maps, models, fiducials and planned screws "
          "are set aside in the session (set_aside/), not deleted; the new CT starts without them.")
           .arg(current)});
  if (!yes) return std::nullopt;
  params["replace"] = true;
  return params;
}

void MainWindow::chooseAndImportLabelMap() {
  if (!session_) {
    presentError(tr("Import label map"), tr("No session is open. Open or create a session first."));
    return;
  }
  if (const auto params = askLabelMapImport(this, *session_)) runStep(QStringLiteral("import-label-map"), *params);
}

void MainWindow::chooseAndMakeModels() {
  if (!session_) {
    presentError(tr("Make models"), tr("No session is open. Open or create a session first."));
    return;
  }
  if (const auto params = askMakeModels(this, *session_)) runStep(QStringLiteral("make-models"), *params);
}

void MainWindow::chooseAndImportShapeModel() {
  const QString path = QFileDialog::getOpenFileName(this, tr("Soft-tissue shape model"), QString(),
                                                    tr("statismo models (*.h5);;All files (*)"));
  if (!path.isEmpty()) runStep(QStringLiteral("shape-model"), {{"path", path.toStdString()}});
}

void MainWindow::chooseAndRunPivot() {
  const QString path = QFileDialog::getOpenFileName(
      this, tr("Pivot calibration: recording"), QString(),
      tr("PLUS sequence or pose CSV (*.mha *.mhd *.nrrd *.csv);;All files (*)"));
  if (!path.isEmpty()) runPivotCalibration(path);
}

bool MainWindow::saveScreenshot(const QString& png) {
  // The window as the user sees it once its pending layouts have run (a panel whose text just changed may need
  // a second pass: a wrapped label's height follows its width).
  for (int pass = 0; pass < 3; ++pass) QCoreApplication::sendPostedEvents(nullptr, QEvent::LayoutRequest);
  display_->render();
  const QPixmap pixmap = grab();
  if (pixmap.isNull() || !pixmap.save(png, "PNG")) {
    presentError(tr("Screenshot"), tr("Could not write %1. Check that its folder exists and is writable.").arg(png));
    return false;
  }
  return true;
}

}  // namespace mrsns::gui
