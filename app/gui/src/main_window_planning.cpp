// MainWindow's screw planning: the planning dock, placing a screw's ends and
// fiducials by clicking on the slices or the 3D bone, dragging a screw's ends
// on the slices with its figures recomputed as it moves, and the trajectory
// view along the selected screw.
#include <QDockWidget>
#include <QFileDialog>
#include <QStatusBar>
#include <algorithm>
#include <sstream>

#include "display_area.h"
#include "area_dock.h"
#include "main_window.h"
#include "message_presenter.h"
#include "mrsns/core/error.h"
#include "mrsns/core/log.h"
#include "mrsns/rendering/scene.h"
#include "mrsns/rendering/slice_views.h"
#include "mrsns/rendering/tool_models.h"
#include "mrsns/workflow/planning.h"
#include "mrsns/workflow/session.h"
#include "mrsns/workflow/steps.h"
#include "planning_panel.h"
#include "session_import.h"

namespace mrsns::gui {

namespace {

Eigen::Vector3d screwTip(const workflow::PlannedScrew& s) {
  const Eigen::Vector3d d = (s.target - s.entry).normalized();
  return s.entry + (s.length_mm > 0.0 ? s.length_mm : (s.target - s.entry).norm()) * d;
}

/// What decides the anatomy's content: each model's file and when it was made.
std::string anatomyKey(const workflow::Session& session) {
  std::ostringstream key;
  for (const auto& m : session.models()) {
    key << m.id << '|' << m.file << '|' << workflow::modelRoleName(m.role) << '|' << m.provenance.time << ';';
  }
  return key.str();
}

}  // namespace

void MainWindow::buildPlanning() {
  planning_ = new PlanningPanel;
  planning_dock_ = makeAreaDock(this, tr("Planning"), QStringLiteral("planningArea"), planning_, Qt::Vertical);
  addDockWidget(Qt::LeftDockWidgetArea, planning_dock_);
  tabifyDockWidget(preparation_dock_, planning_dock_);
  preparation_dock_->raise();

  connect(planning_, &PlanningPanel::windowLevelChanged, this, [this](double window, double level) {
    if (!display_->slices().hasVolume()) return;
    display_->slices().setWindowLevel(window, level);
    display_->renderSlices();
  });
  connect(planning_, &PlanningPanel::screwSelected, this, [this](const QString&) {
    updateSliceOverlays();
    showTrajectory();
    display_->renderSlices();
  });
  connect(planning_, &PlanningPanel::trajectoryToggled, this, [this](bool) {
    showTrajectory();
    display_->renderSlices();
  });
  connect(planning_, &PlanningPanel::newScrewRequested, this, [this] { beginNewScrew(); });
  connect(planning_, &PlanningPanel::placeFiducialRequested, this, [this] {
    if (!session_ || refusePlanningEdit(tr("Place fiducial"))) return;
    const Eigen::Vector3d p = display_->slices().cursor();
    try {
      workflow::runStep(*session_, "place-fiducial",
                        {{"position", nlohmann::json::array({p.x(), p.y(), p.z()})}});
    } catch (const mrsns::Error& e) {
      presentError(tr("Place fiducial"), QString::fromStdString(e.what()));
    }
    refreshPlanning();
  });
  connect(planning_, &PlanningPanel::deleteFiducialRequested, this, [this](const QString& label) {
    if (!session_ || refusePlanningEdit(tr("Delete fiducial"))) return;
    try {
      workflow::runStep(*session_, "place-fiducial", {{"label", label.toStdString()}, {"remove", true}});
    } catch (const mrsns::Error& e) {
      presentError(tr("Delete fiducial"), QString::fromStdString(e.what()));
    }
    refreshPlanning();
  });
  connect(planning_, &PlanningPanel::findFiducialsRequested, this, [this] { runStep(QStringLiteral("find-fiducials")); });
  connect(planning_, &PlanningPanel::deleteScrewRequested, this, [this](const QString& name) {
    if (!session_ || refusePlanningEdit(tr("Delete screw"))) return;
    workflow::removePlannedScrew(*session_, name.toStdString());
    session_->log("info", "planning: removed screw " + name.toStdString());
    refreshPlanning();
  });
  connect(planning_, &PlanningPanel::screwEdited, this,
          [this](const QString& name, const QString& new_name, const QString& vertebra, const QString& side,
                 double diameter, double length) {
            if (!session_) return;
            auto screw = session_->plan(name.toStdString());
            if (!screw) return;
            screw->name = new_name.isEmpty() ? screw->name : new_name.toStdString();
            screw->vertebra = vertebra.toStdString();
            screw->side = side.toStdString();
            screw->diameter_mm = diameter;
            screw->length_mm = length;
            if (planScrew(*screw, name.toStdString())) planning_->selectScrew(QString::fromStdString(screw->name));
          });
  connect(planning_, &PlanningPanel::importPlanRequested, this, [this] {
    const QString path = QFileDialog::getOpenFileName(this, tr("Import plan"), QString(),
                                                      tr("3D Slicer markups (*.mrk.json *.json);;All files (*)"));
    if (!path.isEmpty()) runStep(QStringLiteral("import-plan"), {{"path", path.toStdString()}});
  });
  connect(planning_, &PlanningPanel::exportPlanRequested, this, [this] {
    const QString path = QFileDialog::getSaveFileName(this, tr("Export plan"), QStringLiteral("Plan.mrk.json"),
                                                      tr("3D Slicer markups (*.mrk.json)"));
    if (!path.isEmpty()) runStep(QStringLiteral("export-plan"), {{"path", path.toStdString()}});
  });
  connect(display_, &DisplayArea::slicePointPicked, this, &MainWindow::onPicked);
  connect(display_, &DisplayArea::surfacePointPicked, this, &MainWindow::onPicked);
  connect(display_, &DisplayArea::screwEndDragged, this,
          [this](std::size_t screw, int end, const Eigen::Vector3d& p) { onScrewEndDragged(screw, end, p, false); });
  connect(display_, &DisplayArea::screwEndReleased, this,
          [this](std::size_t screw, int end, const Eigen::Vector3d& p) { onScrewEndDragged(screw, end, p, true); });
}

bool MainWindow::refusePlanningEdit(const QString& what) {
  if (!session_) {
    presentError(what, tr("No session is open. Open one (Ctrl+O) first."));
    return true;
  }
  return refuseWhileBusy(what);
}

workflow::PlanningAnatomyCache* MainWindow::planningAnatomy() {
  if (!session_) return nullptr;
  const std::string key = anatomyKey(*session_);
  if (!anatomy_ || key != anatomy_key_) {
    try {
      anatomy_ = std::make_unique<workflow::PlanningAnatomyCache>(*session_);
      anatomy_key_ = key;
    } catch (const mrsns::Error& e) {
      anatomy_.reset();
      presentError(tr("Planning"), QString::fromStdString(e.what()));
    }
  }
  return anatomy_.get();
}

void MainWindow::refreshPlanning() {
  if (!session_) {
    shown_plan_.clear();
    planning_->setPlan({});
    planning_->setFiducials({});
    return;
  }
  shown_plan_ = session_->plans();
  planning_->setPlan(shown_plan_);
  const auto fiducials = session_->fiducials();
  planning_->setFiducials(fiducials ? fiducials->points : std::vector<workflow::FiducialPoint>{});
  if (display_->slices().hasVolume()) {
    const auto wl = display_->slices().windowLevel();
    planning_->setWindowLevel(wl.x(), wl.y());
  }
  refreshScenePlan();
  updateSliceOverlays();
  showTrajectory();
  display_->render();
}

void MainWindow::refreshScenePlan() {
  auto& scene = display_->scene();
  for (const auto& name : scene.names()) {
    if (name.rfind("path:", 0) == 0) scene.remove(name);
  }
  for (const auto& screw : shown_plan_) {
    const Eigen::Vector3d direction = (screw.target - screw.entry).normalized();
    const Eigen::Vector3d rgb = screwColor(screw);
    scene.setScrewPath("path:" + screw.name, screw.entry, screwTip(screw), screw.diameter_mm, rgb);
    scene.setScrewPath("path:" + screw.name + " approach", screw.entry - 30.0 * direction, screw.entry, 1.2, rgb);
  }
  if (session_) {
    if (const auto fiducials = session_->fiducials()) {
      for (const auto& f : fiducials->points) {
        scene.setMesh("path:fiducial " + f.label, rendering::sphereMesh(f.position_ct, 1.5),
                      Eigen::Vector3d(0.3, 0.8, 1.0), 1.0);
      }
    }
  }
  applyLayerVisibility(scene, DisplayLayer::PlannedPaths, true);
}

void MainWindow::updateSliceOverlays() {
  if (!display_->slices().hasVolume()) return;
  std::vector<rendering::SliceScrew> screws;
  const QString selected = planning_->selectedScrew();
  for (const auto& s : shown_plan_) {
    rendering::SliceScrew v;
    v.name = s.name;
    v.entry = s.entry;
    v.tip = screwTip(s);
    v.diameter_mm = s.diameter_mm;
    v.rgb = screwColor(s);
    v.selected = QString::fromStdString(s.name) == selected;
    screws.push_back(v);
  }
  display_->slices().setScrews(screws);
  std::vector<rendering::SliceMarker> markers;
  if (session_) {
    if (const auto fiducials = session_->fiducials()) {
      for (const auto& f : fiducials->points) markers.push_back({f.label, f.position_ct, {0.3, 0.8, 1.0}});
    }
  }
  if (placing_ == Placing::ScrewTarget) markers.push_back({"entry", placing_entry_, {1.0, 0.85, 0.2}});
  display_->slices().setMarkers(markers);
}

void MainWindow::showTrajectory() {
  const QString selected = planning_->selectedScrew();
  const auto it = std::find_if(shown_plan_.begin(), shown_plan_.end(),
                               [&](const auto& s) { return QString::fromStdString(s.name) == selected; });
  const bool show = planning_->trajectoryShown() && it != shown_plan_.end() && display_->slices().hasVolume();
  if (show) {
    const Eigen::Vector3d tip = screwTip(*it);
    display_->slices().setTrajectory(it->entry, tip, it->diameter_mm, 0.5 * (tip - it->entry).norm());
  } else {
    display_->slices().clearTrajectory();
  }
  display_->setTrajectoryVisible(show);
}

bool MainWindow::beginNewScrew() {
  if (refusePlanningEdit(tr("New screw"))) return false;
  if (!session_->ct()) {
    presentError(tr("New screw"), tr("The session has no CT: import the patient's CT first (Data > Import CT)."));
    return false;
  }
  placing_ = Placing::ScrewEntry;
  display_->setPickMode(true);
  planning_->setHint(tr("Click the screw's entry on a slice or on the bone in the 3D view (Esc cancels)"));
  return true;
}

bool MainWindow::beginPlaceFiducial() {
  if (refusePlanningEdit(tr("Place fiducial"))) return false;
  placing_ = Placing::Fiducial;
  display_->setPickMode(true);
  planning_->setHint(tr("Click the fiducial on a slice or on the bone in the 3D view (Esc cancels)"));
  return true;
}

void MainWindow::cancelPlacing() {
  placing_ = Placing::None;
  display_->setPickMode(false);
  planning_->setHint({});
  updateSliceOverlays();
  display_->renderSlices();
}

void MainWindow::onPicked(const Eigen::Vector3d& p) {
  switch (placing_) {
    case Placing::None: return;
    case Placing::Fiducial: {
      cancelPlacing();
      try {
        workflow::runStep(*session_, "place-fiducial", {{"position", nlohmann::json::array({p.x(), p.y(), p.z()})}});
      } catch (const mrsns::Error& e) {
        presentError(tr("Place fiducial"), QString::fromStdString(e.what()));
      }
      refreshPlanning();
      return;
    }
    case Placing::ScrewEntry:
      placing_entry_ = p;
      placing_ = Placing::ScrewTarget;
      planning_->setHint(tr("Now click the screw's target (where its tip points)"));
      updateSliceOverlays();
      display_->renderSlices();
      return;
    case Placing::ScrewTarget: {
      workflow::PlannedScrew screw;
      screw.entry = placing_entry_;
      screw.target = p;
      screw.diameter_mm = planning_->newDiameter();
      screw.length_mm = planning_->newLength();
      cancelPlacing();
      // A name from the anatomy ("L2 left") when the screw lies in a named vertebra, else "Screw N".
      nlohmann::json figures;
      if (auto* anatomy = planningAnatomy()) {
        try {
          figures = anatomy->evaluate(screw);
        } catch (const mrsns::Error&) {
          // planScrew says what is wrong with it
        }
      }
      screw.name = workflow::nameForNewScrew(shown_plan_, figures);
      if (planScrew(screw)) planning_->selectScrew(QString::fromStdString(screw.name));
      return;
    }
  }
}

bool MainWindow::planScrew(const workflow::PlannedScrew& screw, const std::string& replaces) {
  if (refusePlanningEdit(tr("Plan screw"))) return false;
  auto* anatomy = planningAnatomy();
  if (anatomy == nullptr) return false;
  try {
    const auto saved = workflow::savePlannedScrew(*session_, screw, *anatomy, replaces);
    session_->log("info", "planning: " + saved.name + (replaces.empty() ? " planned" : " updated"));
  } catch (const mrsns::Error& e) {
    presentError(tr("Plan screw"), QString::fromStdString(e.what()));
    refreshPlanning();
    return false;
  }
  refreshPlanning();
  return true;
}

void MainWindow::onScrewEndDragged(std::size_t index, int end, const Eigen::Vector3d& p, bool released) {
  if (!session_ || index >= shown_plan_.size()) return;
  if (navigating() || tasks_->busy()) return;  // the session is in use: the plan stays as it is
  auto& screw = shown_plan_[index];
  const Eigen::Vector3d& moved = p;  // in the view's plane, at the end's own depth across it (DisplayArea)
  if (end == 0) {
    screw.entry = moved;
  } else {
    // Dragging the tip sets the target there; a fixed length keeps following the new direction.
    screw.target = moved;
  }
  if ((screw.target - screw.entry).norm() < 1.0) return;
  // The figures (breach along the screw, clearance to every structure) take several milliseconds on a
  // clinical CT's models: during the drag they are recomputed ten times a second while the screw follows
  // every move; the release computes them (savePlannedScrew) for what is kept.
  constexpr auto kDragFiguresInterval = std::chrono::milliseconds(100);
  const auto now = std::chrono::steady_clock::now();
  if (!released && now - drag_figures_at_ >= kDragFiguresInterval) {
    drag_figures_at_ = now;
    if (auto* anatomy = planningAnatomy()) {
      try {
        screw.figures = anatomy->evaluate(screw);
      } catch (const mrsns::Error&) {
        // a degenerate intermediate position: shown without figures until the next move
      }
    }
  }
  if (released) {
    const auto committed = screw;
    planScrew(committed, committed.name);
    return;
  }
  planning_->updateScrew(screw);
  const Eigen::Vector3d direction = (screw.target - screw.entry).normalized();
  display_->scene().setScrewPath("path:" + screw.name, screw.entry, screwTip(screw), screw.diameter_mm,
                                 screwColor(screw));
  display_->scene().setScrewPath("path:" + screw.name + " approach", screw.entry - 30.0 * direction, screw.entry, 1.2,
                                 screwColor(screw));
  updateSliceOverlays();
  showTrajectory();
  // The slice and trajectory views (where the end is dragged) follow every move; the 3D view, whose bone
  // models take a software renderer some 20 ms even decimated, follows at 15 Hz (bench_gui BM_ScrewDragging).
  constexpr auto kDragSceneInterval = std::chrono::milliseconds(66);
  if (now - drag_scene_at_ >= kDragSceneInterval) {
    drag_scene_at_ = now;
    display_->render();
  } else {
    display_->renderSlices();
  }
}

}  // namespace mrsns::gui
