// MainWindow's sessions: open, create, save, save as, the sample session's
// working copy, and showing what a session holds (read-outs, step states,
// scene).
#include <QDir>
#include <QLabel>
#include <QStandardPaths>
#include <QStatusBar>
#include <filesystem>

#include "display_area.h"
#include "function_panel.h"
#include "main_window.h"
#include "message_presenter.h"
#include "mrsns/core/error.h"
#include "mrsns/igtlink/server.h"
#include "mrsns/rendering/scene.h"
#include "mrsns/rendering/slice_views.h"
#include "mrsns/tracking/hologram_streamer.h"
#include "mrsns/workflow/session.h"
#include "mrsns/workflow/steps.h"
#include "output_panel.h"
#include "session_import.h"
#include "task_runner.h"

namespace mrsns::gui {
namespace {

QString toQ(const std::string& s) {
  return QString::fromStdString(s);
}
std::filesystem::path toPath(const QString& s) {
  return std::filesystem::path(s.toStdString());
}

}  // namespace

// ---------------------------------------------------------------- sessions

QString MainWindow::sessionFolder() const {
  return session_ ? QString::fromStdString(session_->folder().string()) : QString();
}

nlohmann::json MainWindow::sessionState() const {
  return session_ ? session_->state() : nlohmann::json();
}

bool MainWindow::openSession(const QString& folder) {
  if (refuseWhileBusy(tr("Open session"))) return false;
  try {
    auto opened = std::make_unique<workflow::Session>(workflow::Session::open(toPath(folder)));
    stopHologramStream();
    session_ = std::move(opened);
  } catch (const mrsns::Error& e) {
    presentError(tr("Cannot open the session"), QString::fromStdString(e.what()));
    return false;
  }
  rememberSession(folder);
  showSession();
  emit sessionOpened(sessionFolder());
  return true;
}

bool MainWindow::openSampleSession() {
  QString work = options_.sample_work_folder;
  if (work.isEmpty()) {
    work = QStandardPaths::writableLocation(QStandardPaths::AppDataLocation) + QStringLiteral("/sample-session");
  }
  try {
    // The bundled sample is read-only once installed: work on a copy, made
    // once, so a user's steps on the sample survive a restart.
    const auto copy = toPath(work);
    if (!std::filesystem::exists(copy / "session.json")) {
      std::filesystem::remove_all(copy);
      std::filesystem::create_directories(copy.parent_path());
      std::filesystem::copy(workflow::sampleSessionPath(), copy, std::filesystem::copy_options::recursive);
    }
  } catch (const mrsns::Error& e) {
    presentError(tr("Cannot open the sample session"), QString::fromStdString(e.what()));
    return false;
  } catch (const std::filesystem::filesystem_error& e) {
    presentError(tr("Cannot open the sample session"),
                 tr("Copying the sample session to %1 failed: %2. Check that the folder is writable, or open "
                    "another session (Ctrl+O).")
                     .arg(work, QString::fromStdString(e.what())));
    return false;
  }
  return openSession(work);
}

bool MainWindow::createSession(const QString& folder) {
  if (refuseWhileBusy(tr("New session"))) return false;
  try {
    auto created = std::make_unique<workflow::Session>(workflow::Session::create(toPath(folder)));
    stopHologramStream();
    session_ = std::move(created);
  } catch (const mrsns::Error& e) {
    presentError(tr("Cannot create the session"), QString::fromStdString(e.what()));
    return false;
  }
  rememberSession(folder);
  showSession();
  emit sessionOpened(sessionFolder());
  return true;
}

bool MainWindow::saveSession() {
  if (!session_) {
    presentError(tr("Save session"), tr("No session is open. Open one (Ctrl+O) or create one (Ctrl+N) first."));
    return false;
  }
  if (refuseWhileBusy(tr("Save session"))) return false;
  try {
    session_->save();
  } catch (const mrsns::Error& e) {
    presentError(tr("Cannot save the session"), QString::fromStdString(e.what()));
    return false;
  }
  statusBar()->showMessage(tr("Session saved to %1").arg(sessionFolder()), 4000);
  return true;
}

bool MainWindow::saveSessionAs(const QString& folder) {
  if (!saveSession()) return false;
  const auto target = toPath(folder);
  try {
    if (std::filesystem::exists(target) && !std::filesystem::is_empty(target)) {
      presentError(tr("Save session as"), tr("%1 exists and is not empty. Choose a new or empty folder.").arg(folder));
      return false;
    }
    std::filesystem::create_directories(target);
    std::filesystem::copy(session_->folder(), target, std::filesystem::copy_options::recursive);
  } catch (const std::filesystem::filesystem_error& e) {
    presentError(tr("Save session as"), tr("Copying the session to %1 failed: %2. Check the folder's permissions and "
                                           "free space.")
                                            .arg(folder, QString::fromStdString(e.what())));
    return false;
  }
  return openSession(folder);
}

void MainWindow::showSession() {
  const QString folder = sessionFolder();
  setWindowTitle(tr("MR-SNS — %1").arg(QDir(folder).dirName()));
  preparation_->setSessionText(QDir(folder).dirName(), folder);
  session_status_->setText(tr("Session: %1").arg(folder));
  const nlohmann::json state = session_->state();
  output_->showSessionState(state);
  if (state.contains("steps") && state["steps"].is_object()) {
    for (const auto& info : workflow::listSteps()) {
      const QString name = toQ(info.name);
      if (!state["steps"].contains(info.name)) {
        setStepState(name, StepState::NotRun, {});
        continue;
      }
      const auto& record = state["steps"][info.name];
      const std::string status = record.value("status", std::string());
      const bool ok = status == "ok" || status == "done";
      setStepState(name, ok ? StepState::Done : StepState::Failed,
                   stepHeadline(record.value("figures", nlohmann::json::object())));
    }
  }
  populateScene();
}

void MainWindow::populateScene() {
  meshes_.clear();
  auto& scene = display_->scene();
  scene.clear();
  try {
    meshes_ = loadSessionScene(*session_, scene, display_->slices());
  } catch (const mrsns::Error& e) {
    presentError(tr("Some session data could not be shown"), QString::fromStdString(e.what()));
  }
  for (auto layer : {DisplayLayer::Vertebrae, DisplayLayer::SoftTissue, DisplayLayer::PlannedPaths, DisplayLayer::Tools,
                     DisplayLayer::Ultrasound}) {
    applyLayerVisibility(scene, layer, function_->layerVisible(layer));
  }
  // Without a CT the slice views would be three black boxes: give the 3D view the room.
  display_->setSliceViewsVisible(function_->layerVisible(DisplayLayer::SliceViews) && display_->slices().hasVolume());
  display_->resetCamera();
}

}  // namespace mrsns::gui
