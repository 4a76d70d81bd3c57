#include "live_soft_tissue.h"

#include <fmt/format.h>

#include <Eigen/SVD>
#include <algorithm>
#include <chrono>
#include <cmath>

#include "mrsns/core/error.h"
#include "mrsns/core/log.h"
#include "mrsns/core/mesh_locator.h"
#include "mrsns/core/mesh_ops.h"
#include "mrsns/core/parallel.h"
#include "mrsns/core/shape_model.h"
#include "mrsns/deformation/bmode.h"
#include "mrsns/deformation/shape_tracker.h"
#include "mrsns/io/statismo_io.h"
#include "mrsns/robot/safety_supervisor.h"
#include "mrsns/ultrasound/image_chain.h"

namespace mrsns::workflow::detail {
namespace {

// Probe poses kept for placing frames: a few seconds covers any temporal calibration.
constexpr double kPoseHistoryS = 5.0;
// The GUI and the HMD see the whole posterior mesh at most this often; the supervisor gets every update.
constexpr double kMeshIntervalS = 0.2;
constexpr std::size_t kMaxSamples = 200000;
// How long a frame waits for the tracker's pose after its instant (a tracker at 20 Hz or more sends one sooner).
constexpr double kPoseWaitS = 0.1;
// Poses further apart than this around a frame's instant are not interpolated (a tool was lost between them).
constexpr double kMaxPoseGapS = 0.1;

// The frame's pixels as the segmenter's grey levels (0..1), resampled to square pixels of the finer spacing
// when the calibration's spacing differs between columns and rows.
deformation::BModeImage toBMode(const tracking::TrackedImage& image, const Eigen::Vector2d& spacing) {
  const int w = static_cast<int>(image.geometry.size[0]);
  const int h = static_cast<int>(image.geometry.size[1]);
  deformation::BModeImage out;
  const double s = std::min(spacing.x(), spacing.y());
  out.spacing_mm = s;
  if (std::abs(spacing.x() - spacing.y()) <= 1e-3 * s) {
    out.width = w;
    out.height = h;
    out.pixels.resize(static_cast<std::size_t>(w) * h);
    for (std::size_t i = 0; i < out.pixels.size(); ++i) out.pixels[i] = image.pixels[i] / 255.0f;
    return out;
  }
  out.width = static_cast<int>(std::floor((w - 1) * spacing.x() / s)) + 1;
  out.height = static_cast<int>(std::floor((h - 1) * spacing.y() / s)) + 1;
  out.pixels.resize(static_cast<std::size_t>(out.width) * out.height);
  for (int r = 0; r < out.height; ++r) {
    const double y = std::min(r * s / spacing.y(), h - 1.0);
    const int y0 = std::min(static_cast<int>(y), h - 2 < 0 ? 0 : h - 2);
    const double fy = h > 1 ? y - y0 : 0.0;
    for (int c = 0; c < out.width; ++c) {
      const double x = std::min(c * s / spacing.x(), w - 1.0);
      const int x0 = std::min(static_cast<int>(x), w - 2 < 0 ? 0 : w - 2);
      const double fx = w > 1 ? x - x0 : 0.0;
      auto px = [&](int cc, int rr) {
        return image.pixels[static_cast<std::size_t>(std::min(rr, h - 1)) * w + std::min(cc, w - 1)] / 255.0;
      };
      const double v = (1 - fy) * ((1 - fx) * px(x0, y0) + fx * px(x0 + 1, y0)) +
                       fy * ((1 - fx) * px(x0, y0 + 1) + fx * px(x0 + 1, y0 + 1));
      out.pixels[static_cast<std::size_t>(r) * out.width + c] = static_cast<float>(v);
    }
  }
  return out;
}

double distanceToSegment(const Eigen::Vector3d& p, const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  const Eigen::Vector3d ab = b - a;
  const double t = std::clamp((p - a).dot(ab) / std::max(ab.squaredNorm(), 1e-12), 0.0, 1.0);
  return (p - (a + t * ab)).norm();
}

}  // namespace

LiveSoftTissue::LiveSoftTissue(SoftTissueOptions options, std::vector<registration::ScrewPath> paths_ct,
                               std::function<double()> clock, EventSink events)
    : options_(std::move(options)), clock_(std::move(clock)), events_(std::move(events)) {
  if (options_.shape_model.empty()) return;
  ShapeModel model;
  try {
    model = io::readStatismoModel(options_.shape_model);
  } catch (const Error& e) {
    refuse(fmt::format("the shape model {} cannot be read: {}", options_.shape_model.string(), e.what()));
    return;
  }
  model_T_ct_ = options_.ct_T_model.inverse();
  const Eigen::Index n_points = model.mean.size() / 3;
  if (options_.ct_bounds && !options_.ct_bounds->isEmpty() && n_points > 0) {
    Eigen::AlignedBox3d box = *options_.ct_bounds;
    box.extend(box.min() - Eigen::Vector3d::Constant(5.0));
    box.extend(box.max() + Eigen::Vector3d::Constant(5.0));
    Eigen::Index inside = 0;
    for (Eigen::Index i = 0; i < n_points; ++i) {
      if (box.contains(options_.ct_T_model * Eigen::Vector3d(model.mean.segment<3>(3 * i)))) ++inside;
    }
    const double fraction = static_cast<double>(inside) / static_cast<double>(n_points);
    if (fraction < 0.9) {
      refuse(fmt::format("the shape model's mean shape lies outside the CT ({:.0f} % of its points inside): the "
                         "model is in another frame than the CT; place it in this CT (shape-model step) first",
                         100.0 * fraction));
      return;
    }
  }
  if (!options_.calibrated_probe.empty() && options_.calibrated_probe != options_.probe_transform) {
    refuse(fmt::format("the spatial calibration was made with the probe '{}', the source's probe is '{}': "
                       "calibrate this probe (us-spatial-calibration)",
                       options_.calibrated_probe, options_.probe_transform));
    return;
  }
  const Eigen::Matrix4d& a = options_.probe_T_pixel;
  const Eigen::Vector3d ci = a.block<3, 1>(0, 0), cj = a.block<3, 1>(0, 1);
  pixel_spacing_ = Eigen::Vector2d(ci.norm(), cj.norm());
  if (!a.allFinite() || !(pixel_spacing_.minCoeff() > 1e-6) ||
      std::abs(ci.normalized().dot(cj.normalized())) > 0.1) {
    refuse("the spatial calibration (ImageToProbe) has no usable pixel axes: calibrate the probe again");
    return;
  }
  Eigen::Matrix3d r;
  r.col(0) = ci / pixel_spacing_.x();
  r.col(1) = cj / pixel_spacing_.y();
  r.col(2) = r.col(0).cross(r.col(1));
  // The calibration's affine is rigid up to its pixel scale and round-off: the nearest rotation.
  const Eigen::JacobiSVD<Eigen::Matrix3d> svd(r, Eigen::ComputeFullU | Eigen::ComputeFullV);
  probe_T_image_.linear() = svd.matrixU() * svd.matrixV().transpose();
  probe_T_image_.translation() = a.block<3, 1>(0, 3);

  deformation::ShapeTrackerOptions tracker_options;
  // The built-in segmenter sometimes locks onto the wrong lumen: frames that make the posterior implausible
  // are undone (as in the deformation trial).
  tracker_options.reject_implausible_frames = true;
  tracker_options.posterior.noise_sigma_mm = options_.observation_sd_mm;
  tracker_options.max_observation_age_frames = options_.observation_lifetime_frames;
  try {
    tracker_ = std::make_unique<deformation::PosteriorShapeTracker>(std::move(model), tracker_options);
  } catch (const Error& e) {
    refuse(fmt::format("the shape model {} cannot be used: {}", options_.shape_model.string(), e.what()));
    return;
  }
  prepareSupervisorRegion(paths_ct);
  state_ = "waiting for frames";
}

LiveSoftTissue::~LiveSoftTissue() {
  stop();
}

void LiveSoftTissue::setSurfaceSink(SurfaceSink sink) {
  sink_ = std::move(sink);
}

void LiveSoftTissue::setMeshSink(MeshSink sink) {
  mesh_sink_ = std::move(sink);
}

bool LiveSoftTissue::active() const {
  std::lock_guard lock(mutex_);
  return tracker_ && refusal_.empty();
}

void LiveSoftTissue::refuse(const std::string& why) {
  {
    std::lock_guard lock(mutex_);
    if (!refusal_.empty()) return;
    refusal_ = why;
    state_ = "refused: " + why;
  }
  logger()->warn("navigation: soft tissue: {}", why);
  if (events_) events_("soft-tissue-refused", why + "; navigation goes on without the deformation");
}

void LiveSoftTissue::prepareSupervisorRegion(const std::vector<registration::ScrewPath>& paths_ct) {
  const ShapeModel& model = tracker_->model();
  const Eigen::Index n_points = model.mean.size() / 3;
  std::vector<Eigen::Index> index_of(static_cast<std::size_t>(n_points), -1);
  for (Eigen::Index i = 0; i < n_points; ++i) {
    const Eigen::Vector3d p = options_.ct_T_model * Eigen::Vector3d(model.mean.segment<3>(3 * i));
    for (const auto& path : paths_ct) {
      const Eigen::Vector3d end = path.entry + path.direction() * path.effectiveLength();
      if (distanceToSegment(p, path.entry, end) <= options_.supervisor_radius_mm) {
        index_of[static_cast<std::size_t>(i)] = static_cast<Eigen::Index>(region_vertices_.size());
        region_vertices_.push_back(i);
        break;
      }
    }
  }
  std::vector<Eigen::Vector3i> faces;
  const auto& f = model.reference.faces;
  for (Eigen::Index k = 0; k < f.rows(); ++k) {
    const Eigen::Index a = index_of[f(k, 0)], b = index_of[f(k, 1)], c = index_of[f(k, 2)];
    if (a >= 0 && b >= 0 && c >= 0) faces.emplace_back(a, b, c);
  }
  region_faces_.resize(static_cast<Eigen::Index>(faces.size()), 3);
  for (std::size_t k = 0; k < faces.size(); ++k) region_faces_.row(static_cast<Eigen::Index>(k)) = faces[k].transpose();
  const Eigen::Index n = model.modeCount();
  const Eigen::Index m = static_cast<Eigen::Index>(region_vertices_.size());
  region_q_.resize(3 * m, n);
  region_mean_.resize(3 * m);
  const Eigen::RowVectorXd scale = model.variances.cwiseMax(0.0).cwiseSqrt().transpose();
  for (Eigen::Index v = 0; v < m; ++v) {
    const Eigen::Index i = region_vertices_[static_cast<std::size_t>(v)];
    region_mean_.segment<3>(3 * v) = model.mean.segment<3>(3 * i);
    for (int d = 0; d < 3; ++d) region_q_.row(3 * v + d) = model.basis.row(3 * i + d).cwiseProduct(scale);
  }
  if (region_faces_.rows() > 0) {
    TriangleMesh mesh;
    mesh.vertices.resize(m, 3);
    for (Eigen::Index v = 0; v < m; ++v) {
      mesh.vertices.row(v) = (options_.ct_T_model * Eigen::Vector3d(region_mean_.segment<3>(3 * v))).transpose();
    }
    mesh.faces = region_faces_;
    region_locator_ = std::make_shared<MeshLocator>(mesh);
  }
}

std::shared_ptr<const robot::SoftTissueSurface> LiveSoftTissue::supervisorSurface() const {
  if (!region_locator_) return nullptr;
  const Eigen::Index m = static_cast<Eigen::Index>(region_vertices_.size());
  const Eigen::VectorXd shape = region_mean_ + region_q_ * tracker_->coefficients();
  // Eq. 11 per vertex: Q_v Sigma_alpha Q_v^T; its trace is the vertex's 3D variance (an upper bound of the
  // variance along any direction, the surface's normal included).
  // As |Q_v L|_F with Sigma = L L^T, in blocks of vertices that stay in cache, on both cores: the 3m x n by
  // n x n product is most of the work of a frame's margin for a 20k-vertex region.
  const Eigen::LLT<Eigen::MatrixXd> llt(tracker_->coefficientCovariance());
  const Eigen::MatrixXd l = llt.matrixL();
  PointsN3 vertices(m, 3);
  std::vector<double> vertex_sd(static_cast<std::size_t>(m));
  constexpr Eigen::Index kBlock = 256;
  const auto blocks = static_cast<std::size_t>((m + kBlock - 1) / kBlock);
  parallelForBlocks(
      0, blocks,
      [&](std::size_t first, std::size_t last) {
        Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor> ql;
        for (std::size_t b = first; b < last; ++b) {
          const Eigen::Index v0 = static_cast<Eigen::Index>(b) * kBlock;
          const Eigen::Index nv = std::min(kBlock, m - v0);
          ql.noalias() = region_q_.middleRows(3 * v0, 3 * nv) * l.triangularView<Eigen::Lower>();
          for (Eigen::Index v = v0; v < v0 + nv; ++v) {
            vertices.row(v) = (options_.ct_T_model * Eigen::Vector3d(shape.segment<3>(3 * v))).transpose();
            vertex_sd[static_cast<std::size_t>(v)] = std::sqrt(ql.middleRows(3 * (v - v0), 3).squaredNorm());
          }
        }
      },
      0, 4);
  auto surface = std::make_shared<robot::SoftTissueSurface>();
  // The prior's tree with the posterior's vertices: O(faces), where a build is O(faces log faces) (the
  // posterior moves the tissue by millimetres, so the tree's grouping stays good).
  surface->surface = std::make_shared<MeshLocator>(region_locator_->refitted(vertices));
  surface->face_sd_mm.resize(static_cast<std::size_t>(region_faces_.rows()));
  for (Eigen::Index k = 0; k < region_faces_.rows(); ++k) {
    const double sd = std::max({vertex_sd[region_faces_(k, 0)], vertex_sd[region_faces_(k, 1)],
                                vertex_sd[region_faces_(k, 2)]});
    surface->face_sd_mm[static_cast<std::size_t>(k)] = sd;
    surface->max_sd_mm = std::max(surface->max_sd_mm, sd);
  }
  return surface;
}

void LiveSoftTissue::start() {
  if (!tracker_ || running_.exchange(true)) return;
  // The prior, before any frame: the supervisor keeps the drill away from where the tissue may be.
  const double now = clock_();
  if (sink_) {
    try {
      if (auto surface = supervisorSurface()) {
        sink_(surface, now);
        std::lock_guard lock(mutex_);
        counts_.soft_tissue_sd_max_mm = surface->max_sd_mm;
      }
    } catch (const std::exception& e) {
      refuse(std::string("the soft tissue near the planned paths cannot be handed to the supervisor: ") + e.what());
    }
  }
  {
    std::lock_guard lock(mutex_);
    quit_ = false;
    mesh_ct_ = std::make_shared<TriangleMesh>(transformMesh(tracker_->currentMesh(), options_.ct_T_model));
  }
  thread_ = std::thread([this] { run(); });
}

void LiveSoftTissue::stop() {
  if (!running_.exchange(false)) return;
  {
    std::lock_guard lock(mutex_);
    quit_ = true;
  }
  wake_.notify_all();
  {
    std::lock_guard lock(pose_mutex_);
    pose_arrived_.notify_all();
  }
  if (thread_.joinable()) thread_.join();
  // The worker has ended: the last posterior's mesh (updates within kMeshIntervalS were not meshed).
  auto mesh = std::make_shared<const TriangleMesh>(transformMesh(tracker_->currentMesh(), options_.ct_T_model));
  if (mesh_sink_) mesh_sink_(mesh);
  std::lock_guard lock(mutex_);
  mesh_ct_ = std::move(mesh);
}

void LiveSoftTissue::observe(std::span<const tracking::ToolUpdate> batch) {
  // A PlusServer sends each tool in its own TRANSFORM message: the probe and the patient are kept apart and
  // each interpolated at a frame's instant.
  std::lock_guard lock(pose_mutex_);
  bool added = false;
  for (const auto& u : batch) {
    std::deque<FramePose>* history = u.name == options_.probe_transform     ? &tracker_T_probe_
                                     : u.name == options_.patient_transform ? &tracker_T_patient_
                                                                            : nullptr;
    if (!history || u.status != TransformStatus::Ok || !std::isfinite(u.timestamp)) continue;
    if (!history->empty() && !(u.timestamp > history->back().timestamp)) continue;
    history->push_back(FramePose{0, u.timestamp, u.to_T_from, TransformStatus::Ok});
    while (history->front().timestamp < u.timestamp - kPoseHistoryS) history->pop_front();
    added = true;
  }
  if (added) pose_arrived_.notify_all();
}

void LiveSoftTissue::push(const tracking::TrackedImage& image) {
  const double now = clock_();
  {
    std::lock_guard lock(mutex_);
    ++counts_.us_frames_received;
    if (!tracker_ || !refusal_.empty() || quit_) return;
    if (pending_) ++counts_.us_frames_skipped;
    pending_.emplace(image, now);
  }
  wake_.notify_one();
}

void LiveSoftTissue::run() {
  while (true) {
    std::pair<tracking::TrackedImage, double> job;
    {
      std::unique_lock lock(mutex_);
      wake_.wait(lock, [this] { return quit_ || pending_.has_value(); });
      if (quit_) return;
      job = std::move(*pending_);
      pending_.reset();
    }
    try {
      process(std::move(job.first), job.second);
    } catch (const std::exception& e) {
      refuse(std::string("the deformation failed: ") + e.what());
    }
  }
}

void LiveSoftTissue::process(tracking::TrackedImage image, double arrived_s) {
  const auto& g = image.geometry;
  const int w = static_cast<int>(g.size[0]);
  const int h = static_cast<int>(g.size[1]);
  if (image.format.scalar != PixelType::UInt8 || image.format.components != 1 || g.size[2] != 1 ||
      image.pixels.size() != static_cast<std::size_t>(w) * static_cast<std::size_t>(h)) {
    refuse(fmt::format("the source's frames are not 8-bit grey 2D images ({} components of {} bytes, {} x {} x {})",
                       image.format.components, pixelTypeSize(image.format.scalar), g.size[0], g.size[1], g.size[2]));
    return;
  }
  if (options_.image_width > 0 && (w != options_.image_width || h != options_.image_height)) {
    refuse(fmt::format("the source's frames are {} x {} pixels, the spatial calibration is for {} x {}: another "
                       "probe or depth setting; calibrate it (us-spatial-calibration) or restore the setting",
                       w, h, options_.image_width, options_.image_height));
    return;
  }
  const double needed = image.timestamp + options_.tracker_lag_s;
  std::vector<FramePose> probe_poses, patient_poses;
  {
    // Video and tracking arrive on their own: the poses just after the frame's instant may still be on their way.
    std::unique_lock lock(pose_mutex_);
    auto after = [&](const std::deque<FramePose>& poses) { return !poses.empty() && poses.back().timestamp >= needed; };
    pose_arrived_.wait_for(lock, std::chrono::duration<double>(kPoseWaitS), [&] {
      return !running_ || (after(tracker_T_probe_) && after(tracker_T_patient_));
    });
    probe_poses.assign(tracker_T_probe_.begin(), tracker_T_probe_.end());
    patient_poses.assign(tracker_T_patient_.begin(), tracker_T_patient_.end());
  }
  // A tool lost around the frame's instant: no interpolation across the gap.
  auto tracked_at = [&](const std::vector<FramePose>& poses) {
    const auto it = std::lower_bound(poses.begin(), poses.end(), needed,
                                     [](const FramePose& p, double t) { return p.timestamp < t; });
    return it != poses.end() && it->timestamp - needed <= kMaxPoseGapS && it != poses.begin() &&
           needed - std::prev(it)->timestamp <= kMaxPoseGapS;
  };
  Eigen::Isometry3d patient_T_probe;
  if (tracked_at(probe_poses) && tracked_at(patient_poses)) {
    patient_T_probe = ultrasound::probePoseAtVideoTime(patient_poses, image.timestamp, options_.tracker_lag_s).inverse() *
                      ultrasound::probePoseAtVideoTime(probe_poses, image.timestamp, options_.tracker_lag_s);
  } else {
    std::lock_guard lock(mutex_);
    ++counts_.us_frames_refused;  // the probe or the patient not tracked around the frame's instant
    return;
  }
  const Eigen::Isometry3d ct_T_image = options_.patient_T_ct.inverse() * patient_T_probe * probe_T_image_;
  const Eigen::Isometry3d model_T_image = model_T_ct_ * ct_T_image;

  const std::vector<Polyline3d> seeds = tracker_->predictedContours(model_T_image);
  if (seeds.empty()) {
    std::lock_guard lock(mutex_);
    ++counts_.us_frames_off_tissue;
    return;
  }
  const deformation::BModeImage bmode = toBMode(image, pixel_spacing_);
  const std::vector<deformation::LumenContour> lumens = deformation::segmentLumens(bmode, seeds);
  std::vector<Polyline3d> features;
  for (const auto& l : lumens) {
    if (l.ok) features.push_back(l.contour);
  }
  const deformation::FrameUpdate u = tracker_->update(model_T_image, features);
  std::shared_ptr<const robot::SoftTissueSurface> surface;
  if (u.updated && sink_) {
    surface = supervisorSurface();
    if (surface) sink_(surface, arrived_s);
  }
  const double done_s = clock_();

  LiveUltrasoundFrame frame;
  Eigen::Matrix4d image_T_pixel = Eigen::Matrix4d::Identity();
  image_T_pixel(0, 0) = pixel_spacing_.x();
  image_T_pixel(1, 1) = pixel_spacing_.y();
  frame.ct_T_pixel = ct_T_image.matrix() * image_T_pixel;
  for (const auto& f : features) {
    Polyline3d ct;
    ct.closed = f.closed;
    ct.points.reserve(f.points.size());
    for (const auto& p : f.points) ct.points.push_back(ct_T_image * p);
    frame.lumens_ct.push_back(std::move(ct));
  }
  frame.image = std::move(image);
  std::shared_ptr<const TriangleMesh> mesh;
  if (u.updated && done_s - last_mesh_s_ >= kMeshIntervalS) {
    last_mesh_s_ = done_s;
    mesh = std::make_shared<TriangleMesh>(transformMesh(tracker_->currentMesh(), options_.ct_T_model));
    if (mesh_sink_) mesh_sink_(mesh);
  }
  std::lock_guard lock(mutex_);
  ++counts_.us_frames_used;
  state_ = "tracking";
  frame.index = counts_.us_frames_used;
  latest_ = std::move(frame);
  if (mesh) mesh_ct_ = std::move(mesh);
  if (u.updated) {
    ++counts_.soft_tissue_updates;
    counts_.soft_tissue_observations = u.observations;
    if (surface) counts_.soft_tissue_sd_max_mm = surface->max_sd_mm;
    counts_.us_frame_to_margin_ms = 1e3 * (done_s - arrived_s);
    if (samples_.size() < kMaxSamples) {
      samples_.push_back(
          SoftTissueSample{latest_->image.timestamp, tracker_->coefficients(), u.observations, u.matched_contours,
                           counts_.us_frame_to_margin_ms});
    }
  }
}

void LiveSoftTissue::fillStatus(NavigationStatus& status) const {
  std::lock_guard lock(mutex_);
  status.soft_tissue = state_;
  status.us_frames_received = counts_.us_frames_received;
  status.us_frames_used = counts_.us_frames_used;
  status.us_frames_skipped = counts_.us_frames_skipped;
  status.us_frames_refused = counts_.us_frames_refused;
  status.us_frames_off_tissue = counts_.us_frames_off_tissue;
  status.soft_tissue_updates = counts_.soft_tissue_updates;
  status.soft_tissue_observations = counts_.soft_tissue_observations;
  status.soft_tissue_sd_max_mm = counts_.soft_tissue_sd_max_mm;
  status.us_frame_to_margin_ms = counts_.us_frame_to_margin_ms;
}

std::vector<SoftTissueSample> LiveSoftTissue::samples() const {
  std::lock_guard lock(mutex_);
  return samples_;
}

std::optional<LiveUltrasoundFrame> LiveSoftTissue::latestFrame() const {
  std::lock_guard lock(mutex_);
  return latest_;
}

std::shared_ptr<const TriangleMesh> LiveSoftTissue::currentMeshCt() const {
  std::lock_guard lock(mutex_);
  return mesh_ct_;
}

}  // namespace mrsns::workflow::detail
