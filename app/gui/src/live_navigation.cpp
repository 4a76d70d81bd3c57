#include "live_navigation.h"

#include <QStringList>
#include <QTimer>
#include <cmath>
#include <cstring>

#include "display_area.h"
#include "function_panel.h"
#include "live_deformation.h"
#include "mrsns/core/error.h"
#include "mrsns/core/log.h"
#include "mrsns/core/mesh_locator.h"
#include "mrsns/rendering/scene.h"
#include "mrsns/rendering/tool_models.h"
#include "mrsns/webxr/webxr_hologram_service.h"
#include "output_panel.h"

namespace mrsns::gui {
namespace {

// The simulated stylus pivots about its tip 150 mm from its marker
// (tracking::PivotMotion's default); a real stylus gets this offset from
// its pivot calibration.
const Eigen::Vector3d kSimulatedStylusTip(0.0, 0.0, -150.0);
// Plots keep the last few minutes; the recording keeps everything.
constexpr std::size_t kMaxSeries = 6000;

struct ToolView {
  const char* object;
  const char* frame;  // tracked frame whose pose in the patient frame places the object
};
// The stylus model is drawn in its tip frame, the others in their marker frame.
constexpr ToolView kTools[] = {
    {kStylusObject, "StylusTip"}, {kProbeObject, "Probe"}, {kFlangeObject, "Flange"}, {kDrillObject, "Drill"}};

nlohmann::json finiteOrNull(double v) {
  return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json(nullptr);
}

/// The supervisor's stop figures (the reason names its stop already), once
/// the loop has them (robot in the loop only).
QString stopDetail(const workflow::NavigationStatus& st) {
  if (st.robot == "none") return {};
  QStringList parts;
  // An operator's stop has no lost sample to count from.
  if (!st.operator_stopped && std::isfinite(st.stop_latency_ms)) {
    parts << QObject::tr("stop sent %1 ms (%2 cycles) after the loss")
                 .arg(st.stop_latency_ms, 0, 'f', 2)
                 .arg(st.stop_latency_cycles);
  }
  if (std::isfinite(st.time_to_stop_s)) {
    parts << QObject::tr("arm at rest %1 ms later").arg(st.time_to_stop_s * 1e3, 0, 'f', 0);
  }
  return parts.join(QStringLiteral(" · "));
}

void pushBounded(std::vector<double>& v, double x) {
  if (v.size() >= kMaxSeries) v.erase(v.begin());
  v.push_back(x);
}

}  // namespace

std::optional<Eigen::Isometry3d> ctFromPatient(const workflow::Session& session) {
  const auto registration = session.transform("CTToPatient");
  if (!registration) return std::nullopt;
  return Eigen::Isometry3d(registration->matrix).inverse();
}

LiveNavigation::LiveNavigation(DisplayArea* display, OutputPanel* output, FunctionPanel* function, QObject* parent)
    : QObject(parent), display_(display), output_(output), function_(function), timer_(new QTimer(this)) {
  timer_->setObjectName(QStringLiteral("navigationTimer"));
  connect(timer_, &QTimer::timeout, this, &LiveNavigation::poll);
}

LiveNavigation::~LiveNavigation() {
  if (loop_) loop_->stop();
}

void LiveNavigation::start(const LiveNavigationSetup& setup) {
  stop();
  workflow::NavigationOptions options = setup.options;
  if (options.hologram_forward_transforms.empty() && options.devices.source == "simulated") {
    // The HMD (or a Slicer client) sees the tracked tools move even before an
    // HMD calibration places the models in its hologram frame.
    options.hologram_forward_transforms = workflow::simulatedToolNames();
    if (options.robot.robot != "none") options.hologram_forward_transforms.push_back(options.robot.tool_transform);
  }
  auto loop = std::make_unique<workflow::NavigationLoop>(options);
  // The models live in the CT (Preop) frame; the registration places it in the patient frame.
  if (!setup.world_T_patient.isApprox(Eigen::Isometry3d::Identity())) {
    loop->repository().setTransform("Preop", "Patient", setup.world_T_patient.inverse(), TransformStatus::Ok,
                                    std::numeric_limits<double>::quiet_NaN(), true);
  }
  if (setup.options.devices.source == "simulated") {
    Eigen::Isometry3d stylus_T_tip = Eigen::Isometry3d::Identity();
    stylus_T_tip.translation() = kSimulatedStylusTip;
    loop->repository().setTransform("StylusTip", "Stylus", stylus_T_tip, TransformStatus::Ok,
                                    std::numeric_limits<double>::quiet_NaN(), true);
  }
  retireDeformation();
  deformation_time_s_.clear();
  deformation_mm_.clear();
  deformation_prior_mm_ = std::numeric_limits<double>::quiet_NaN();
  shown_frame_ = 0;
  shown_mesh_.reset();
  if (setup.track_deformation && setup.options.soft_tissue.shape_model.empty()) {
    LiveDeformationOptions deformation_options;
    deformation_options.seed = setup.options.devices.seed;
    // At the tracker's rate, one ultrasound frame about every 50 ms.
    deformation_options.batches_per_frame =
        std::max(1, static_cast<int>(std::lround(setup.options.devices.rate_hz / 20.0)));
    deformation_ = std::make_shared<LiveDeformation>(deformation_options);
    loop->setDeformationHook([d = deformation_](const TransformRepository&, double time_s) { d->onBatch(time_s); });
  }
  locator_.reset();
  if (!setup.distance_target.empty()) locator_ = std::make_unique<MeshLocator>(setup.distance_target);
  setup_ = setup;
  setup_.distance_target = {};  // the locator holds what it needs
  latency_ms_.clear();
  tissue_time_s_.clear();
  tissue_mm_.clear();
  last_batches_ = 0;
  last_latency_sum_ms_ = 0.0;
  stop_reported_ = false;
  output_->beginLiveNavigation();
  loop->start();
  loop_ = std::move(loop);
  clock_.start();
  started_ = QDateTime::currentDateTime();
  addTools();
  timer_->start(setup.poll_interval_ms);
  logger()->info("live navigation started ({} tracker)", setup.options.devices.source);
}

void LiveNavigation::addTools() {
  if (!loop_) return;
  auto& scene = display_->scene();
  scene.setTool(kStylusObject, rendering::ToolKind::Stylus, Eigen::Vector3d(0.95, 0.85, 0.30));
  scene.setMesh(kProbeObject, rendering::boxMesh(Eigen::Vector3d(-20.0, -8.0, -5.0), Eigen::Vector3d(20.0, 40.0, 5.0)),
                Eigen::Vector3d(0.45, 0.85, 0.55));
  scene.setTool(kFlangeObject, rendering::ToolKind::EndEffector, Eigen::Vector3d(0.70, 0.72, 0.78));
  scene.setTool(kDrillObject, rendering::ToolKind::Drill, Eigen::Vector3d(0.85, 0.55, 0.25));
  for (const auto& tool : kTools) scene.setVisible(tool.object, false);  // until tracked
}

void LiveNavigation::moveTools() {
  auto& scene = display_->scene();
  const bool layer_on = function_->layerVisible(DisplayLayer::Tools);
  const auto& repository = loop_->repository();
  for (const auto& tool : kTools) {
    if (!scene.contains(tool.object)) continue;
    bool ok = false;
    if (repository.hasFrame(tool.frame) && repository.hasFrame("Patient")) {
      try {
        const auto r = repository.getTransform(tool.frame, "Patient");
        ok = r.ok();
        if (ok) scene.setPose(tool.object, setup_.world_T_patient * r.to_T_from);
      } catch (const mrsns::Error&) {
        ok = false;  // not connected yet
      }
    }
    // A lost tool disappears rather than freezing at its last pose.
    scene.setVisible(tool.object, ok && layer_on);
  }
}

bool LiveNavigation::showLiveSoftTissue() {
  if (setup_.options.soft_tissue.shape_model.empty()) return false;
  auto& scene = display_->scene();
  const bool layer_on = function_->layerVisible(DisplayLayer::Ultrasound);
  const auto frame = loop_->liveUltrasound();
  if (frame && frame->index != shown_frame_) {
    shown_frame_ = frame->index;
    const auto& g = frame->image.geometry;
    ImageVolume image;
    image.size = {static_cast<int>(g.size[0]), static_cast<int>(g.size[1]), 1};
    image.pixel_type = PixelType::UInt8;
    image.data.resize(frame->image.pixels.size());
    std::memcpy(image.data.data(), frame->image.pixels.data(), frame->image.pixels.size());
    try {
      // The scene's world is the CT; the frame was placed there by Eq. 4 with the session's calibrations.
      scene.setUltrasoundSlice(kUltrasoundObject, image, frame->ct_T_pixel);
      scene.setPolylines(kUltrasoundOutlineObject, frame->lumens_ct, Eigen::Vector3d(0.2, 1.0, 0.4));
    } catch (const mrsns::Error& e) {
      logger()->warn("live ultrasound frame not shown: {}", e.what());
    }
  }
  for (const char* name : {kUltrasoundObject, kUltrasoundOutlineObject}) {
    if (scene.contains(name)) scene.setVisible(name, frame.has_value() && layer_on);
  }
  // The posterior mean (refreshed by the loop at most every 0.2 s): the soft-tissue model's vertices moved.
  if (auto mesh = loop_->softTissueMesh(); mesh && mesh != shown_mesh_ && !setup_.soft_tissue_object.empty() &&
                                           scene.contains(setup_.soft_tissue_object)) {
    shown_mesh_ = mesh;
    try {
      scene.updateMeshVertices(setup_.soft_tissue_object, mesh->vertices);
    } catch (const mrsns::Error& e) {
      logger()->warn("soft-tissue model not updated: {}", e.what());  // a model of another topology is shown
    }
  }
  return true;
}

void LiveNavigation::showUltrasound() {
  if (showLiveSoftTissue()) return;
  if (!deformation_) return;
  auto& scene = display_->scene();
  ImageVolume image;
  Eigen::Matrix4d probe_T_pixel;
  int frame = -1;
  const bool have = deformation_->latestImage(image, probe_T_pixel, frame);
  bool ok = false;
  const auto& repository = loop_->repository();
  if (have && repository.hasFrame("Probe") && repository.hasFrame("Patient")) {
    try {
      const auto r = repository.getTransform("Probe", "Patient");
      ok = r.ok();
      if (ok) {
        const Eigen::Matrix4d world_T_pixel = (setup_.world_T_patient * r.to_T_from).matrix() * probe_T_pixel;
        // A frame of the same size reuses the texture; the probe moves every poll.
        scene.setUltrasoundSlice(kUltrasoundObject, image, world_T_pixel);
      }
    } catch (const mrsns::Error&) {
      ok = false;
    }
  }
  if (scene.contains(kUltrasoundObject)) {
    scene.setVisible(kUltrasoundObject, ok && function_->layerVisible(DisplayLayer::Ultrasound));
  }
}

void LiveNavigation::retireDeformation() {
  if (deformation_) retired_deformations_.push_back(std::move(deformation_));
  deformation_.reset();
}

void LiveNavigation::poll() {
  std::erase_if(retired_deformations_, [](const auto& d) { return d->built() && d.use_count() == 1; });
  if (!loop_) return;
  const workflow::NavigationStatus st = loop_->status();
  const double t = static_cast<double>(clock_.elapsed()) * 1e-3;
  moveTools();
  showUltrasound();
  display_->renderScene();

  // Mean loop latency of the batches since the last poll, from the running mean.
  double latency_ms = std::nan("");
  const double sum_ms = st.mean_loop_latency_ms * static_cast<double>(st.batches);
  if (st.batches > last_batches_) {
    latency_ms = (sum_ms - last_latency_sum_ms_) / static_cast<double>(st.batches - last_batches_);
    last_batches_ = st.batches;
    last_latency_sum_ms_ = sum_ms;
    pushBounded(latency_ms_, latency_ms);
  }
  double tissue_mm = std::nan("");
  if (locator_) {
    const auto& repository = loop_->repository();
    if (repository.hasFrame("StylusTip") && repository.hasFrame("Patient")) {
      try {
        const auto r = repository.getTransform("StylusTip", "Patient");
        if (r.ok()) {
          const Eigen::Vector3d tip_world = setup_.world_T_patient * r.to_T_from.translation();
          tissue_mm = locator_->closestPoint(tip_world).distance;
          pushBounded(tissue_time_s_, t);
          pushBounded(tissue_mm_, tissue_mm);
        }
      } catch (const mrsns::Error&) {
      }
    }
  }
  if (deformation_) {
    for (const auto& sample : deformation_->takeSamples()) {
      if (sample.frame < 0 && std::isnan(deformation_prior_mm_)) deformation_prior_mm_ = sample.error_mm;
      pushBounded(deformation_time_s_, sample.time_s);
      pushBounded(deformation_mm_, sample.error_mm);
      output_->showDeformationSample(sample.time_s, sample.error_mm);
    }
  }
  output_->showLiveSample(t, tissue_mm, latency_ms,
                          st.robot_stopped ? tr("robot stopped") : QStringLiteral("ok"));  // the banner says why
  const QString robot = st.robot == "none" ? QString()
                                           : tr(" · robot %1 %2, drill depth %3 mm")
                                                 .arg(QString::fromStdString(st.supervisor_state),
                                                      QString::fromStdString(st.guidance_phase).toLower())
                                                 .arg(st.depth_mm, 0, 'f', 1);
  const QString tissue =
      st.soft_tissue == "off"
          ? QString()
          : tr(" · soft tissue %1 (%2 updates from %3 of %4 frames)")
                .arg(QString::fromStdString(st.soft_tissue))
                .arg(st.soft_tissue_updates)
                .arg(st.us_frames_used)
                .arg(st.us_frames_received);
  output_->setNavigationStatus(
      tr("navigating %1 s · %2 batches · %3 frames recorded · tracker %4%5%6%7")
          .arg(t, 0, 'f', 1)
          .arg(st.batches)
          .arg(st.frames_recorded)
          .arg(QString::fromUtf8(tracking::toString(st.source.state).data()))
          .arg(st.recorder_error.empty() ? QString()
                                         : tr(" · recording failed: %1").arg(QString::fromStdString(st.recorder_error)))
          .arg(robot, tissue));

  if (st.hologram_port != 0) {
    function_->setStreaming(
        true,
        tr("serving %1 clients on 127.0.0.1:%2 with the live tracking").arg(st.hologram_clients).arg(st.hologram_port));
  }
  // A new stop, or the reason changed under a stop in force (an operator
  // pause that a tracking loss turned into a safety stop): report it.
  if (st.robot_stopped && (!stop_reported_ || QString::fromStdString(st.stop_reason) != stop_reason_)) {
    stop_reported_ = true;
    // The latest stop event carries when (since start) the stop happened.
    double at_s = t;
    for (const auto& e : loop_->events()) {
      if (e.kind == "safety-stop" || e.kind == "operator-stop") at_s = e.time_s;
    }
    const QDateTime when = started_.addMSecs(static_cast<qint64>(std::llround(at_s * 1e3)));
    stop_reason_ = QString::fromStdString(st.stop_reason);
    stop_when_ = tr("%1 (%2 s after start)").arg(when.toString(QStringLiteral("HH:mm:ss.zzz"))).arg(at_s, 0, 'f', 2);
    stop_detail_ = stopDetail(st);
    output_->showRobotStop(stop_reason_, stop_detail_.isEmpty() ? stop_when_ : stop_when_ + "\n" + stop_detail_);
    emit robotStopped(stop_reason_, when);
  } else if (st.robot_stopped && stopDetail(st) != stop_detail_) {
    // The stop latency and the time to rest arrive after the stop itself.
    stop_detail_ = stopDetail(st);
    output_->showRobotStop(stop_reason_, stop_when_ + "\n" + stop_detail_);
  } else if (!st.robot_stopped && stop_reported_) {
    stop_reported_ = false;  // re-armed
    output_->clearRobotStop();
  }
}

bool LiveNavigation::rearm() {
  if (!loop_) return false;
  if (loop_->rearm()) return true;
  QString why = tr("the supervisor refused");
  for (const auto& e : loop_->events()) {
    if (e.kind == "rearm-refused") why = QString::fromStdString(e.message);
  }
  emit rearmRefused(why);
  return false;
}

bool LiveNavigation::stopRobot(const QString& reason) {
  if (!loop_) return false;
  const bool ok = loop_->stopRobot(reason.toStdString());
  poll();  // the banner at once, not at the next tick
  return ok;
}

std::uint16_t LiveNavigation::streamHolograms(std::vector<tracking::HologramModel> models, int port,
                                              const std::string& client) {
  if (!loop_) return 0;
  return loop_->streamHolograms(std::move(models), port, client);
}

webxr::WebXrHologramService& LiveNavigation::serveWebXr(std::vector<tracking::HologramModel> models,
                                                        webxr::WebXrServiceOptions options) {
  if (!loop_) throw InvalidArgumentError("the WebXR client can be handed to live navigation only while it runs");
  return loop_->serveWebXr(std::move(models), std::move(options));
}

void LiveNavigation::stopWebXr() {
  if (loop_) loop_->stopWebXr();
}

void LiveNavigation::stopHologramStream() {
  if (loop_) loop_->stopHologramStream();
}

workflow::NavigationStatus LiveNavigation::status() const {
  return loop_ ? loop_->status() : workflow::NavigationStatus{};
}

nlohmann::json LiveNavigation::stop() {
  if (!loop_) return nullptr;
  timer_->stop();
  poll();  // the last status and a banner the timer has not shown yet
  loop_->stop();
  const workflow::NavigationStatus st = loop_->status();
  nlohmann::json events = nlohmann::json::array();
  for (const auto& e : loop_->events()) {
    events.push_back({{"time_s", e.time_s}, {"kind", e.kind}, {"message", e.message}});
  }
  nlohmann::json figures = {{"live", true},
                            {"source", setup_.options.devices.source},
                            {"duration_s", static_cast<double>(clock_.elapsed()) * 1e-3},
                            {"batches", st.batches},
                            {"frames_recorded", st.frames_recorded},
                            {"frames_synced", st.frames_synced},
                            {"max_batch_gap_ms", st.max_batch_gap_s * 1e3},
                            {"mean_loop_latency_ms", st.mean_loop_latency_ms},
                            {"robot_stopped", st.robot_stopped},
                            {"stop_reason", st.stop_reason},
                            {"recorder_error", st.recorder_error},
                            {"video_frames_recorded", st.video_frames_recorded},
                            {"video_frames_dropped", st.video_frames_dropped},
                            {"video_error", st.video_error},
                            {"events", events},
                            {"loop_latency_ms", latency_ms_}};
  if (st.robot != "none") {
    figures["robot"] = {{"robot", st.robot},
                        {"supervisor_state", st.supervisor_state},
                        {"supervisor_stop", st.supervisor_stop},
                        {"last_transition", st.last_transition},
                        {"robot_stops", st.robot_stops},
                        {"stop_latency_cycles", st.stop_latency_cycles},
                        {"stop_latency_ms", finiteOrNull(st.stop_latency_ms)},
                        {"time_to_stop_s", finiteOrNull(st.time_to_stop_s)},
                        {"motion_commands", st.motion_commands},
                        {"motion_commands_after_stop", st.motion_commands_after_stop},
                        {"robot_missed_cycles", st.robot_missed_cycles}};
  }
  if (st.soft_tissue != "off") {
    figures["soft_tissue"] = {{"state", st.soft_tissue},
                              {"frames_received", st.us_frames_received},
                              {"frames_used", st.us_frames_used},
                              {"frames_skipped", st.us_frames_skipped},
                              {"frames_refused", st.us_frames_refused},
                              {"updates", st.soft_tissue_updates},
                              {"sd_max_near_path_mm", finiteOrNull(st.soft_tissue_sd_max_mm)},
                              {"frame_to_margin_ms", finiteOrNull(st.us_frame_to_margin_ms)}};
  }
  if (locator_) {
    figures["distance_target"] = setup_.distance_target_name;
    figures["tip_to_tissue_mm"] = tissue_mm_;
    figures["tip_to_tissue_mm_time_s"] = tissue_time_s_;
  }
  if (deformation_) {
    figures["deformation_error_mm"] = deformation_mm_;
    figures["deformation_error_mm_time_s"] = deformation_time_s_;
    figures["deformation_prior_error_mm"] =
        std::isnan(deformation_prior_mm_) ? nlohmann::json(nullptr) : nlohmann::json(deformation_prior_mm_);
    figures["deformation_model"] =
        "simulated carotid sweep (paper 001 III.A), contours of the true cut; error = mean vertex distance of the "
        "posterior shape to the held-out truth";
    const std::string failure = deformation_->failure();
    if (!failure.empty()) figures["deformation_failure"] = failure;
  }
  loop_.reset();
  retireDeformation();
  auto& scene = display_->scene();
  for (const auto& tool : kTools) scene.remove(tool.object);
  scene.remove(kUltrasoundObject);
  scene.remove(kUltrasoundOutlineObject);
  display_->renderScene();
  logger()->info("live navigation stopped: {} batches, {} frames recorded", st.batches, st.frames_recorded);
  return figures;
}

}  // namespace mrsns::gui
