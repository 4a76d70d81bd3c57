#include "camera_operator.h"

#include <cmath>
#include <regex>

#include "mrsns/core/minimum_jerk.h"
#include "mrsns/core/rigid.h"
#include "mrsns/core/units.h"

namespace mrsns::simulation {

namespace {

// "view 3 of 10" in a prompt: the view asked for (1-based) and how many there are.
bool viewAsked(const std::string& prompt, int& view, int& of) {
  static const std::regex pattern(R"(view (\d{1,3}) of (\d{1,3}))");
  std::smatch m;
  if (!std::regex_search(prompt, m, pattern)) return false;
  view = std::stoi(m[1].str());
  of = std::stoi(m[2].str());
  return view >= 1 && of >= view;
}

}  // namespace

CameraOperator::CameraOperator(HeadsetCameraSpec spec, MeasurementVolume volume, std::uint64_t seed)
    : spec_(std::move(spec)), volume_(volume), rng_(seed * 0x9E3779B97F4A7C15ULL + 1234567ULL) {
  true_.fx = spec_.fx;
  true_.fy = spec_.fy;
  true_.cx = spec_.cx;
  true_.cy = spec_.cy;
  true_.distortion = spec_.distortion;
  true_.width = spec_.width;
  true_.height = spec_.height;
  // The device's factory calibration: close to the truth, not equal to it.
  std::normal_distribution<double> n(0.0, 1.0);
  reported_ = true_;
  const double focal = 1.0 + 0.01 * spec_.intrinsics_focal_error_percent * n(rng_);
  reported_.fx *= focal;
  reported_.fy *= focal;
  reported_.cx += spec_.intrinsics_principal_error_px * n(rng_);
  reported_.cy += spec_.intrinsics_principal_error_px * n(rng_);
  std::uniform_real_distribution<double> hz(0.3, 0.7), phase(0.0, 2.0 * kPi);
  sway_hz_ = {hz(rng_), hz(rng_), hz(rng_)};
  sway_phase_ = {phase(rng_), phase(rng_), phase(rng_)};
}

Eigen::Vector3d CameraOperator::sway(double t) const {
  Eigen::Vector3d s;
  for (int k = 0; k < 3; ++k) s[k] = spec_.head_sway_mm * std::sin(2.0 * kPi * sway_hz_[k] * t + sway_phase_[k]);
  return s;
}

std::optional<Eigen::Isometry3d> CameraOperator::chooseView(int view, int of, const Eigen::Isometry3d& tracker_T_board,
                                                            double& distance, double& tilt) {
  const hmd::CheckerboardSpec b = board();
  const Eigen::Vector3d centre(0.5 * (b.cols - 1) * b.square_mm, 0.5 * (b.rows - 1) * b.square_mm, 0.0);
  const Eigen::Isometry3d tracker_T_grid = tracker_T_board * spec_.board_T_grid;
  const Eigen::Isometry3d camera_T_marker = spec_.marker_T_camera.inverse();
  // Nearer views first, as the paper's 0.5-1.5 m.
  const double f = of > 1 ? static_cast<double>(view - 1) / static_cast<double>(of - 1) : 0.5;
  distance = spec_.min_distance_mm + f * (spec_.max_distance_mm - spec_.min_distance_mm);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  for (int attempt = 0; attempt < 400; ++attempt) {
    // The wearer finds a view that works: wider tilts first, smaller ones when those fail.
    const double max_tilt = spec_.max_tilt_deg * kDeg * (1.0 - attempt / 400.0);
    const double theta = max_tilt * std::sqrt(u(rng_)), phi = 2.0 * kPi * u(rng_);
    const double roll = spec_.max_roll_deg * kDeg * (2.0 * u(rng_) - 1.0);
    // The side the corners face is the grid's -z (OpenCV's convention, checkerboard_grid.h).
    const Eigen::Vector3d dir(std::sin(theta) * std::cos(phi), std::sin(theta) * std::sin(phi), -std::cos(theta));
    const Eigen::Vector3d position = centre + distance * dir;
    const Eigen::Vector3d z = (centre - position).normalized();
    // The image's "down" (camera y) as close to the tracker's -y... any fixed reference works: the grid's x.
    const Eigen::Vector3d x = (Eigen::Vector3d::UnitX() - Eigen::Vector3d::UnitX().dot(z) * z).normalized();
    Eigen::Isometry3d grid_T_camera = Eigen::Isometry3d::Identity();
    grid_T_camera.linear() << x, z.cross(x), z;
    grid_T_camera.linear() = grid_T_camera.linear() * so3Exp(Eigen::Vector3d(0.0, 0.0, roll));
    grid_T_camera.translation() = position;
    // The whole board, a square of border included, inside the image with a margin.
    const Eigen::Isometry3d camera_T_grid = grid_T_camera.inverse();
    std::vector<Eigen::Vector3d> outline;
    for (double a : {-2.0 * b.square_mm, (b.cols + 1.0) * b.square_mm}) {
      for (double c : {-2.0 * b.square_mm, (b.rows + 1.0) * b.square_mm}) {
        outline.push_back(camera_T_grid * Eigen::Vector3d(a, c, 0.0));
      }
    }
    bool inside = true;
    for (const auto& p : outline) inside = inside && p.z() > 100.0;
    if (!inside) continue;
    for (const auto& px : hmd::projectPoints(outline, true_)) {
      inside = inside && px.x() > 20.0 && px.y() > 20.0 && px.x() < true_.width - 20.0 && px.y() < true_.height - 20.0;
    }
    if (!inside) continue;
    // The headset's marker must stay in the tracker's volume (with a margin for the sway and the walk).
    const Eigen::Isometry3d headset = tracker_T_grid * grid_T_camera * camera_T_marker;
    const Eigen::Vector3d p = headset.translation();
    const double depth = -p.z();
    if (depth < volume_.near_mm + 50.0 || depth > volume_.far_mm - 50.0 ||
        std::abs(p.x()) > depth * std::tan(volume_.half_angle_x_deg * kDeg) - 50.0 ||
        std::abs(p.y()) > depth * std::tan(volume_.half_angle_y_deg * kDeg) - 50.0) {
      continue;
    }
    tilt = theta / kDeg;
    return headset;
  }
  return std::nullopt;
}

void CameraOperator::onPrompt(double t, const std::string& prompt, const Eigen::Isometry3d& tracker_T_board,
                              const Eigen::Isometry3d& tracker_T_rest) {
  const Eigen::Isometry3d here = last_.value_or(tracker_T_rest);
  int view = 0, of = 0;
  if (prompt.find(spec_.prompt_contains) == std::string::npos || !viewAsked(prompt, view, of)) {
    if (to_ && !returning_) {
      from_ = here;
      to_ = tracker_T_rest;
      start_t_ = t;
      returning_ = true;
      photo_pending_ = false;
    }
    return;
  }
  ViewTruth v;
  v.view = view;
  v.prompt_t = t;
  const auto target = chooseView(view, of, tracker_T_board, v.distance_mm, v.tilt_deg);
  v.reachable = target.has_value();
  views_.push_back(v);
  if (!target) return;  // the wearer cannot find the view: no photo (the workstation waits, then says so)
  from_ = here;
  to_ = *target;
  start_t_ = t;
  returning_ = false;
  photo_pending_ = true;
}

std::optional<Eigen::Isometry3d> CameraOperator::pose(double t, const Eigen::Isometry3d& tracker_T_rest) {
  if (!to_) return std::nullopt;
  const double s = (t - start_t_) / spec_.move_s;
  if (returning_) {
    to_ = tracker_T_rest;
    if (s >= 1.0) {
      from_.reset();
      to_.reset();
      last_.reset();
      returning_ = false;
      return std::nullopt;
    }
    last_ = interpolatePose(*from_, *to_, minimumJerk(s));
    return last_;
  }
  Eigen::Isometry3d held = s >= 1.0 ? *to_ : interpolatePose(*from_, *to_, minimumJerk(std::max(s, 0.0)));
  held.translation() += sway(t);
  last_ = held;
  return held;
}

std::optional<CameraOperator::Photo> CameraOperator::photoDue(double t, const Eigen::Isometry3d& tracker_T_headset,
                                                              const Eigen::Isometry3d& tracker_T_board) {
  if (!photo_pending_ || returning_ || t < start_t_ + spec_.move_s + spec_.settle_s) return std::nullopt;
  photo_pending_ = false;
  views_.back().photo_t = t;
  Photo p;
  p.view = views_.back().view;
  p.camera_T_grid = (tracker_T_headset * spec_.marker_T_camera).inverse() * tracker_T_board * spec_.board_T_grid;
  return p;
}

}  // namespace mrsns::simulation
