#pragma once
// Live navigation in the GUI: workflow::NavigationLoop runs tracking,
// recording and the safety supervisor on its own threads; a QTimer on the GUI
// thread polls NavigationStatus and moves the tools in the scene from the
// loop's (thread-safe) transform repository, so VTK is only ever touched on
// the GUI thread. A robot stop becomes a red banner in the output area, not a
// dialog: nobody should have to click OK while a drill is in the patient.
#include <QDateTime>
#include <QElapsedTimer>
#include <QObject>
#include <QString>
#include <limits>
#include <memory>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "mrsns/core/mesh.h"
#include "mrsns/workflow/navigation.h"
#include "mrsns/workflow/session.h"

class QTimer;

namespace mrsns {
class MeshLocator;
}

namespace mrsns::gui {

class DisplayArea;
class FunctionPanel;
class LiveDeformation;
class OutputPanel;

struct LiveNavigationSetup {
  workflow::NavigationOptions options;
  /// Places the patient frame in the scene (the scene's world is CT mm):
  /// CT_T_patient from the registration, identity without one.
  Eigen::Isometry3d world_T_patient = Eigen::Isometry3d::Identity();
  /// The surface the stylus tip's distance is measured to (world mm), e.g.
  /// the vessel; none when empty.
  TriangleMesh distance_target;
  std::string distance_target_name;
  /// Track the soft tissue (simulated carotid sweep, LiveDeformation) from
  /// the loop's deformation hook: the simulated tracker only. With the live
  /// soft tissue (options.soft_tissue.shape_model set) the source's own
  /// ultrasound is shown and followed instead.
  bool track_deformation = true;
  /// The scene mesh whose vertices the live posterior moves (the shape
  /// model's mean model); none when empty.
  std::string soft_tissue_object;
  /// How often the GUI polls the loop and redraws the view.
  int poll_interval_ms = 50;
};

/// Scene names of the tracked tools the live view draws.
inline constexpr const char* kStylusObject = "tool:Stylus";
inline constexpr const char* kProbeObject = "tool:Probe";
inline constexpr const char* kFlangeObject = "tool:Flange";
/// The live ultrasound frame, at the tracked probe.
inline constexpr const char* kUltrasoundObject = "us:live";
/// The lumens segmented in it (live soft tissue).
inline constexpr const char* kUltrasoundOutlineObject = "us:live-outline";
/// The simulated robot's drill marker (NavigationOptions::robot "simulated").
inline constexpr const char* kDrillObject = "tool:Drill";

class LiveNavigation : public QObject {
  Q_OBJECT
 public:
  LiveNavigation(DisplayArea* display, OutputPanel* output, FunctionPanel* function, QObject* parent = nullptr);
  ~LiveNavigation() override;

  /// Builds and starts the loop. Throws like workflow::NavigationLoop (bad
  /// device options, a recording that cannot be written).
  void start(const LiveNavigationSetup& setup);
  /// Stops the loop and syncs the recording; returns the run's figures
  /// (counts, robot stop, events, and the series the plots show:
  /// loop_latency_ms, tip_to_tissue_mm and deformation_error_mm, each with
  /// its *_time_s).
  /// Null when it was not running.
  nlohmann::json stop();
  [[nodiscard]] bool running() const { return loop_ != nullptr; }
  /// The supervisor's acknowledge: the robot may move again once tracking is
  /// back (it then waits in Ready). False, with rearmRefused(why), when the
  /// loop refuses (tracking still lost, arm still moving).
  bool rearm();
  /// The operator's stop (the "Stop robot" button): the arm stops through
  /// its supervisor, navigation (tracking, recording, plots) goes on; Re-arm
  /// lets it move again. False when not running or the loop refused.
  bool stopRobot(const QString& reason);
  /// Hands the hologram stream to the running loop (its repository, the
  /// tracked tools forwarded); returns the port. Throws like
  /// NavigationLoop::streamHolograms; false-y (0) when not running.
  std::uint16_t streamHolograms(std::vector<tracking::HologramModel> models, int port, const std::string& client);
  void stopHologramStream();
  /// NavigationLoop::serveWebXr while navigation runs. Throws InvalidArgumentError when it does not.
  webxr::WebXrHologramService& serveWebXr(std::vector<tracking::HologramModel> models,
                                          webxr::WebXrServiceOptions options);
  void stopWebXr();
  /// Re-adds the tool objects after the scene was cleared (session reloaded).
  void addTools();
  [[nodiscard]] workflow::NavigationStatus status() const;

 signals:
  /// Once per robot stop, with the reason and when it happened.
  void robotStopped(const QString& reason, const QDateTime& when);
  void rearmRefused(const QString& why);

 private:
  void poll();
  void moveTools();
  void showUltrasound();
  /// The source's frame, its outline and the posterior mesh (live soft tissue); false when it is off.
  bool showLiveSoftTissue();

  DisplayArea* display_;
  OutputPanel* output_;
  FunctionPanel* function_;
  QTimer* timer_;
  std::unique_ptr<workflow::NavigationLoop> loop_;
  LiveNavigationSetup setup_;
  std::unique_ptr<MeshLocator> locator_;
  std::shared_ptr<LiveDeformation> deformation_;
  /// Deformations of ended runs whose sweep may still be building: released
  /// by poll() once built, so the GUI thread never waits for the builder.
  std::vector<std::shared_ptr<LiveDeformation>> retired_deformations_;
  void retireDeformation();
  QElapsedTimer clock_;
  QDateTime started_;
  bool stop_reported_ = false;
  QString stop_reason_, stop_when_, stop_detail_;
  std::uint64_t last_batches_ = 0;
  double last_latency_sum_ms_ = 0.0;
  std::vector<double> latency_ms_;
  std::vector<double> tissue_time_s_, tissue_mm_;
  std::vector<double> deformation_time_s_, deformation_mm_;
  double deformation_prior_mm_ = std::numeric_limits<double>::quiet_NaN();
  std::uint64_t shown_frame_ = 0;
  std::shared_ptr<const TriangleMesh> shown_mesh_;
};

/// CT_T_patient from the session's latest successful registration (CTToPatient, inverted); none without one.
std::optional<Eigen::Isometry3d> ctFromPatient(const workflow::Session& session);

}  // namespace mrsns::gui
