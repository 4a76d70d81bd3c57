// MainWindow's sessions: open, create, save, save as, the sample session's
// working copy, and showing what a session holds (read-outs, step states,
// scene).
#include <QApplication>
#include <QDir>
#include <QLabel>
#include <QStandardPaths>
#include <QStatusBar>
#include <cmath>
#include <filesystem>
#include <numbers>
#include <optional>

#include "display_area.h"
#include "function_panel.h"
#include "live_navigation.h"
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

/// Planned screws enter from behind (+y in LPS): the home view looks at
/// their centre from posterior, lateral and superior (superior up), far
/// enough to keep the vertebrae around them in view. None without a plan.
std::optional<DisplayArea::HomeView> homeViewOnPaths(const workflow::Session& session,
                                                     const std::map<std::string, TriangleMesh>& meshes) {
  std::vector<Eigen::Vector3d> points;
  for (const auto& screw : session.plans()) {
    points.push_back(screw.entry);
    points.push_back(screw.target);
  }
  if (points.empty()) return std::nullopt;
  Eigen::Vector3d centre = Eigen::Vector3d::Zero();
  for (const auto& p : points) centre += p;
  centre /= static_cast<double>(points.size());
  double radius = 0.0;
  for (const auto& p : points) radius = std::max(radius, (p - centre).norm());
  // The vertebrae as a whole (their joint bounding box) around the paths' centre.
  for (const auto& [name, mesh] : meshes) {
    if (name.rfind("vertebra:", 0) != 0 || mesh.vertices.rows() == 0) continue;
    for (Eigen::Index i = 0; i < mesh.vertices.rows(); ++i) {
      radius = std::max(radius, (mesh.vertices.row(i).transpose() - centre).norm());
    }
  }
  radius = std::max(radius, 30.0);
  // VTK's 30 degree view angle: the sphere of `radius` just fits at this distance.
  const double distance = radius / std::tan(15.0 * std::numbers::pi / 180.0) * 1.1;
  DisplayArea::HomeView view;
  view.focal_point = centre;
  view.position = centre + distance * Eigen::Vector3d(0.45, 1.0, 0.5).normalized();
  view.view_up = Eigen::Vector3d::UnitZ();
  return view;
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
  // Preparing the copy writes into it: not under a task or a navigation that may be using it.
  if (refuseWhileBusy(tr("Open the sample session"))) return false;
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
    // The sample's patient is the cervical phantom, generated on demand and never stored: a fresh copy would
    // open to an empty view. Its patient data (CT, segmentation, models, fiducials found in the CT, plan) are
    // imported into the copy, in about two seconds, so the sample opens showing them.
    workflow::Session sample = workflow::Session::open(copy);
    if (!sample.ct()) {
      QApplication::setOverrideCursor(Qt::WaitCursor);
      try {
        workflow::runStep(sample, "import-phantom", {{"spacing_mm", 1.0}});
      } catch (...) {
        QApplication::restoreOverrideCursor();
        throw;
      }
      QApplication::restoreOverrideCursor();
      sample.log("info", "mrsns: imported the phantom patient's data into the fresh sample copy");
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
    meshes_ = loadSessionScene(*session_, scene, display_->slices(), scene_cache_);
  } catch (const mrsns::Error& e) {
    presentError(tr("Some session data could not be shown"), QString::fromStdString(e.what()));
  }
  for (auto layer : {DisplayLayer::Vertebrae, DisplayLayer::SoftTissue, DisplayLayer::PlannedPaths, DisplayLayer::Tools,
                     DisplayLayer::Ultrasound}) {
    applyLayerVisibility(scene, layer, function_->layerVisible(layer));
  }
  // Without a CT the slice views would be three black boxes: give the 3D view the room.
  display_->setSliceViewsVisible(function_->layerVisible(DisplayLayer::SliceViews) && display_->slices().hasVolume());
  live_->addTools();  // the scene was cleared under a running navigation
  display_->setHomeView(homeViewOnPaths(*session_, meshes_));
  refreshPlanning();
  display_->resetCamera();
}

}  // namespace mrsns::gui
