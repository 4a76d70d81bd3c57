#pragma once
// The MR-SNS workstation window (paper 001 Fig. 4): preparation and function
// areas on the left, the display area in the centre, the output area on the
// right, a status bar with the running task's progress and Cancel. Every
// button calls into mrsns::workflow or a module on a worker thread; errors
// reach the user through the MessagePresenter, never as a crash.
#include <QMainWindow>
#include <chrono>
#include <optional>
#include <atomic>
#include <cstdint>
#include <QStringList>
#include <map>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "mrsns/core/mesh.h"
#include "mrsns/workflow/session_document.h"
#include "preparation_panel.h"
#include "session_import.h"
#include "step_list.h"

class QLabel;
class QMenu;
class QProgressBar;
class QPushButton;
class QDockWidget;

namespace mrsns::workflow {
class Session;
class PlanningAnatomyCache;
struct NavigationOptions;
}  // namespace mrsns::workflow
namespace mrsns::tracking {
class HologramStreamer;
struct HologramModel;
}  // namespace mrsns::tracking
namespace mrsns::igtlink {
class Server;
}
namespace mrsns::webxr {
class WebXrHologramService;
struct WebXrServiceOptions;
}  // namespace mrsns::webxr

namespace mrsns::gui {

class DisplayArea;
class FunctionPanel;
class LiveNavigation;
class MessagePresenter;
class OutputPanel;
class PlanningPanel;
class SimulatedRoom;
class TaskRunner;
struct TaskOutcome;

struct MainWindowOptions {
  /// Where user messages go; a DialogPresenter on this window when null.
  std::shared_ptr<MessagePresenter> presenter;
  /// Restore and save geometry, dock layout and recent sessions (QSettings).
  bool remember_window_state = true;
  /// Where the bundled sample session is copied before it is opened (it is
  /// read-only once installed); the user's data location when empty.
  QString sample_work_folder;
};

class MainWindow : public QMainWindow {
  Q_OBJECT
 public:
  explicit MainWindow(MainWindowOptions options = {}, QWidget* parent = nullptr);
  ~MainWindow() override;

  /// Opens a session folder; false (and a message saying what to do) on failure.
  bool openSession(const QString& folder);
  /// Opens a working copy of the bundled sample session.
  bool openSampleSession();
  bool createSession(const QString& folder);
  bool saveSession();
  /// Copies the session folder to `folder` (must not exist or be empty) and opens the copy.
  bool saveSessionAs(const QString& folder);
  [[nodiscard]] bool hasSession() const { return session_ != nullptr; }
  [[nodiscard]] QString sessionFolder() const;
  /// The session's state as last saved (a copy; safe while a task runs).
  [[nodiscard]] nlohmann::json sessionState() const;

  /// Starts a workflow step on the worker; false when refused (no session,
  /// another task running), with a message.
  bool runStep(const QString& step, const nlohmann::json& params = nlohmann::json::object());
  /// The parameters a step runs with from the GUI: source=plus for the ultrasound calibrations once the
  /// session is connected to a PlusServer (connect-devices with source=plus), none otherwise.
  [[nodiscard]] nlohmann::json deviceParams(const QString& step) const;
  /// Reads `path` on the worker, checks it, copies it into the session and shows it.
  bool importFile(ImportKind kind, const QString& path);
  /// Pivot calibration from a CSV of tracker_T_marker poses.
  /// The pivot-calibration step on a PLUS recording (StylusToReference) or a pose CSV.
  bool runPivotCalibration(const QString& recording);
  void cancelTask();
  /// The operator's confirmation (the Confirm button, F8, a foot pedal) to the running step.
  void confirmStep();
  [[nodiscard]] bool taskRunning() const;

  /// Starts live navigation: workflow::NavigationLoop on the simulated
  /// tracker, with the simulated robot following the session's first planned
  /// path when the registration has planned one (as the navigation step's
  /// robot=auto), recording into the session's navigation/ folder; false
  /// (and a message) without a session or while a task runs.
  bool startNavigation();
  /// The same with explicit options; the GUI sets `recording`, and the plan
  /// and patient_T_plan of a "simulated" robot from the session when it has
  /// planned paths.
  bool startNavigation(workflow::NavigationOptions options);
  /// Stops it and records the run as the session's "navigation" step.
  void stopNavigation();
  [[nodiscard]] bool navigating() const;
  LiveNavigation* liveNavigation() const { return live_; }

  /// Serves the session's models to HMD clients on 127.0.0.1:port. While
  /// live navigation runs the navigation loop serves them, from its own
  /// repository, with the tracked tools' transforms (one stream, send-only:
  /// nothing a client sends reaches the loop or the robot); otherwise the
  /// window serves the models alone.
  /// `client` names the headset client's preset (tracking::hologramClientPresets()).
  bool startHologramStream(int port, const std::string& client = "slicer");
  void stopHologramStream();
  [[nodiscard]] bool hologramStreaming() const { return hologram_port_ != 0; }

  /// Serves the WebXR hologram client (a page the headset's browser opens, webxr::WebXrHologramService) on
  /// `port` (0: a free one), on 127.0.0.1 or, `from_network`, every interface. Its address and pairing code
  /// show in the function panel; the code and port stay the same until it is switched off, so a paired page
  /// comes back by itself when live navigation takes the service over (the tools' transforms, the soft
  /// tissue's vertices) and when an HMD step serves it (the cube, the prompts, the page's confirmation).
  /// False, with a message, when it cannot be served.
  bool startWebXr(int port, bool from_network = false);
  void stopWebXr();
  [[nodiscard]] bool webXrServing() const { return webxr_on_; }
  /// The page's pairing code and the bound port (empty, 0 when off).
  [[nodiscard]] std::string webXrPairingCode() const { return webxr_on_ ? webxr_code_ : std::string(); }
  [[nodiscard]] int webXrPort() const { return webxr_on_ ? webxr_port_ : 0; }

  /// Renders the whole window (3D view included) into a PNG.
  bool saveScreenshot(const QString& png);
  [[nodiscard]] QStringList recentSessions() const;

  OutputPanel* outputPanel() const { return output_; }
  PlanningPanel* planningPanel() const { return planning_; }

  // Planning on the slices and the 3D view (main_window_planning.cpp). The
  // session's plan is changed on the GUI thread, in milliseconds, through
  // workflow::savePlannedScrew with the window's cached anatomy; refused
  // (with a message) while a task or navigation uses the session.
  /// Starts placing a new screw: the next two picks are its entry and target.
  bool beginNewScrew();
  /// Starts placing a fiducial: the next pick is its position.
  bool beginPlaceFiducial();
  /// Stops placing (Esc).
  void cancelPlacing();
  /// Adds or replaces a screw as the planning panel does; false with a message when refused.
  bool planScrew(const workflow::PlannedScrew& screw, const std::string& replaces = {});
  /// The plan as the window shows it (a dragged screw's live figures included).
  [[nodiscard]] std::vector<workflow::PlannedScrew> shownPlan() const { return shown_plan_; }
  PreparationPanel* preparationPanel() const { return preparation_; }
  FunctionPanel* functionPanel() const { return function_; }
  DisplayArea* displayArea() const { return display_; }
  TaskRunner* taskRunner() const { return tasks_; }

  /// Starts the simulated operating room (mrsns-sim, its own process) on
  /// `scenario` (the bundled default when empty) for a demonstration; the
  /// status bar marks it SIMULATED while it runs. False with a message when
  /// it cannot start; failures later come as messages too.
  bool startSimulatedRoom(const QString& scenario = {});
  void stopSimulatedRoom();
  /// Runs connect-devices on the simulated room when it is ready, else on a
  /// PlusServer at 127.0.0.1:18944.
  bool connectDevices();
  SimulatedRoom* simulatedRoom() const { return sim_room_; }

 signals:
  void sessionOpened(const QString& folder);
  void taskFinished(const QString& name, bool ok);

 protected:
  void closeEvent(QCloseEvent* event) override;

 private:
  void buildMenus();
  void buildDevicesMenu();
  void buildStatusBar();
  void restoreWindowState();
  void rememberSession(const QString& folder);
  void refreshRecentMenu();
  void showSession();
  void populateScene();
  void onTaskStarted(const QString& name);
  void onTaskProgress(const QString& name, double fraction, const QString& message);
  void onTaskFinished(const QString& name, const TaskOutcome& outcome);
  void setStepState(const QString& step, StepState state, const QString& detail);
  void recordImport(const std::string& record, const TaskOutcome& outcome);
  void presentError(const QString& title, const QString& text);
  /// import-ct's parameters once the user agreed to set the session's CT (and everything made from it) aside,
  /// when it has one; nothing when the user said no.
  std::optional<nlohmann::json> ctImportParams(nlohmann::json params);
  void presentInfo(const QString& title, const QString& text);
  bool refuseWhileBusy(const QString& what);
  void chooseAndOpenSession();
  void chooseAndCreateSession();
  void chooseAndSaveSessionAs();
  void chooseAndImport(ImportKind kind);
  /// A step asked for from a panel or the Workflow menu: the ones that need the user's file or points ask first.
  void requestStep(const QString& step);
  void chooseAndImportDicom();
  void chooseAndImportLabelMap();
  void chooseAndMakeModels();
  void chooseAndImportShapeModel();
  void chooseAndRunPivot();
  void showShortcuts();
  void buildPlanning();
  void refreshPlanning();
  void refreshScenePlan();
  void updateSliceOverlays();
  void showTrajectory();
  workflow::PlanningAnatomyCache* planningAnatomy();
  void onPicked(const Eigen::Vector3d& p_lps);
  void onScrewEndDragged(std::size_t screw, int end, const Eigen::Vector3d& p_lps, bool released);
  bool refusePlanningEdit(const QString& what);

  MainWindowOptions options_;
  std::shared_ptr<MessagePresenter> presenter_;
  std::unique_ptr<workflow::Session> session_;
  std::map<std::string, TriangleMesh> meshes_;  // what the scene shows, for the hologram stream
  PreparationPanel* preparation_ = nullptr;
  FunctionPanel* function_ = nullptr;
  OutputPanel* output_ = nullptr;
  DisplayArea* display_ = nullptr;
  TaskRunner* tasks_ = nullptr;
  LiveNavigation* live_ = nullptr;
  std::string live_recording_;  // relative to the session folder
  QDockWidget* preparation_dock_ = nullptr;
  QDockWidget* function_dock_ = nullptr;
  QDockWidget* output_dock_ = nullptr;
  QProgressBar* progress_ = nullptr;
  QPushButton* cancel_ = nullptr;
  QPushButton* confirm_ = nullptr;
  std::atomic<std::uint64_t> confirmations_{0};
  QLabel* task_label_ = nullptr;
  QLabel* session_status_ = nullptr;
  QLabel* sim_label_ = nullptr;  // SIMULATED banner while mrsns-sim runs
  SimulatedRoom* sim_room_ = nullptr;
  QMenu* recent_menu_ = nullptr;
  PlanningPanel* planning_ = nullptr;
  QDockWidget* planning_dock_ = nullptr;
  SceneFileCache scene_cache_;
  std::unique_ptr<workflow::PlanningAnatomyCache> anatomy_;
  std::string anatomy_key_;  // which models the cached anatomy was built from
  std::vector<workflow::PlannedScrew> shown_plan_;
  // When the dragged screw's figures were last computed: they follow the drag at most every
  // kDragFiguresInterval, the screw itself every mouse move (and both on release).
  std::chrono::steady_clock::time_point drag_figures_at_{};
  // When the 3D view last followed the drag (the slice views follow every move).
  std::chrono::steady_clock::time_point drag_scene_at_{};
  enum class Placing { None, ScrewEntry, ScrewTarget, Fiducial };
  Placing placing_ = Placing::None;
  Eigen::Vector3d placing_entry_ = Eigen::Vector3d::Zero();
  std::unique_ptr<igtlink::Server> stream_server_;
  std::unique_ptr<tracking::HologramStreamer> streamer_;
  int hologram_port_ = 0;  // the stream the user asked for (0: off), kept across navigation start/stop
  std::string hologram_client_ = "slicer";  // and the headset client it is set up for
  bool startWindowStream(int port);
  void stopWindowStream();
  // The WebXR client (webxr_control.cpp): served by the window, the navigation loop or an HMD step in turn.
  std::unique_ptr<webxr::WebXrHologramService> web_;
  bool webxr_on_ = false;
  int webxr_port_ = 0;
  std::string webxr_address_ = "127.0.0.1";
  std::string webxr_code_;
  [[nodiscard]] webxr::WebXrServiceOptions webXrOptions();
  bool startWindowWebXr();
  bool startLoopWebXr();
  void stopWindowWebXr();
  void showWebXrStatus(const QString& mode);
  /// `params` with the WebXR page added for an HMD step (hmd-calibration, checkerboard-digitisation) while the
  /// client is on; the window's service then makes way for the step's.
  nlohmann::json withWebXr(const std::string& step, nlohmann::json params);
  [[nodiscard]] std::vector<tracking::HologramModel> hologramModels() const;
  /// The device name hologramModels() gives the scene mesh `scene_name` (empty when it is not streamed).
  [[nodiscard]] std::string hologramDeviceName(const std::string& scene_name) const;
};

/// The style sheet of the workstation (dark, high contrast read-outs).
QString workstationStyleSheet();

}  // namespace mrsns::gui
