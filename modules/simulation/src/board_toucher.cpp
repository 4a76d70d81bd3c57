#include "board_toucher.h"

#include <cmath>
#include <regex>

#include "mrsns/core/minimum_jerk.h"
#include "mrsns/core/rigid.h"
#include "mrsns/core/units.h"

namespace mrsns::simulation {

namespace {

// "corner 3 of 15" in a prompt: the corner asked for (1-based) and how many there are.
bool cornerAsked(const std::string& prompt, int& corner, int& of) {
  static const std::regex pattern(R"(corner (\d{1,4}) of (\d{1,4}))");
  std::smatch m;
  if (!std::regex_search(prompt, m, pattern)) return false;
  corner = std::stoi(m[1].str());
  of = std::stoi(m[2].str());
  return corner >= 1 && of >= corner;
}

}  // namespace

BoardToucher::BoardToucher(BoardTouchSpec spec, const HeadsetCameraSpec& board, Eigen::Vector3d tip_tool,
                           std::uint64_t seed)
    : spec_(std::move(spec)), board_(board), tip_tool_(std::move(tip_tool)), rng_(seed * 6364136223846793005ULL + 77ULL) {
  std::uniform_real_distribution<double> hz(8.0, 12.0), phase(0.0, 2.0 * kPi);
  tremor_hz_ = {hz(rng_), hz(rng_), hz(rng_)};
  tremor_phase_ = {phase(rng_), phase(rng_), phase(rng_)};
}

Eigen::Isometry3d BoardToucher::toolAtTip(const Eigen::Vector3d& tip_tracker) const {
  Eigen::Isometry3d t = Eigen::Isometry3d::Identity();
  t.linear() = tracker_R_tool_;
  t.translation() = tip_tracker - tracker_R_tool_ * tip_tool_;
  return t;
}

void BoardToucher::onPrompt(double t, const std::string& prompt, const Eigen::Isometry3d& tracker_T_board,
                            const Eigen::Isometry3d& tracker_T_rest) {
  int corner = 0, of = 0;
  const int corners = board_.rows * board_.cols;
  if (prompt.find(spec_.prompt_contains) == std::string::npos || !cornerAsked(prompt, corner, of) ||
      corner > corners) {
    if (active_ && !returning_) {
      from_ = last_.value_or(tracker_T_rest);
      start_t_ = t;
      returning_ = true;
    }
    return;
  }
  if (!active_) tracker_R_tool_ = tracker_T_rest.linear();
  from_ = last_.value_or(tracker_T_rest);
  const int k = corner - 1;
  const Eigen::Vector3d grid(k % board_.cols * board_.square_mm, k / board_.cols * board_.square_mm, 0.0);
  std::normal_distribution<double> n(0.0, spec_.placement_error_mm / std::sqrt(3.0));
  Eigen::Vector3d error(n(rng_), n(rng_), n(rng_));
  // A corner misplaced the first time it is asked for.
  bool asked_before = false;
  for (const auto& touch : touches_) asked_before = asked_before || touch.corner == corner;
  for (const auto& m : spec_.misplaced) {
    if (m.corner == corner && !asked_before) error += m.offset_mm;
  }
  target_ = tracker_T_board * (board_.board_T_grid * grid + error);
  touches_.push_back({corner, t, error});
  start_t_ = t;
  active_ = true;
  returning_ = false;
}

std::optional<Eigen::Isometry3d> BoardToucher::pose(double t, const Eigen::Isometry3d& tracker_T_rest) {
  if (!active_) return std::nullopt;
  const double s = t - start_t_;
  if (returning_) {
    if (s >= spec_.travel_s) {
      active_ = returning_ = false;
      last_.reset();
      return std::nullopt;
    }
    last_ = interpolatePose(*from_, tracker_T_rest, minimumJerk(s / spec_.travel_s));
    return last_;
  }
  // Above the corner along the shaft (towards the marker), down onto it, held, and up again.
  const Eigen::Vector3d up = -(tracker_R_tool_ * tip_tool_).normalized();
  const Eigen::Isometry3d above = toolAtTip(target_ + spec_.approach_mm * up);
  const Eigen::Isometry3d on = toolAtTip(target_);
  const double down_at = spec_.travel_s, hold_at = down_at + spec_.down_s, lift_at = hold_at + spec_.dwell_s;
  if (s < down_at) {
    last_ = interpolatePose(*from_, above, minimumJerk(s / spec_.travel_s));
  } else if (s < hold_at) {
    last_ = interpolatePose(above, on, minimumJerk((s - down_at) / spec_.down_s));
  } else if (s < lift_at) {
    Eigen::Isometry3d held = on;
    for (int k = 0; k < 3; ++k) {
      held.translation()[k] += spec_.tremor_mm * std::sin(2.0 * kPi * tremor_hz_[k] * t + tremor_phase_[k]);
    }
    last_ = held;
  } else {
    last_ = interpolatePose(on, above, minimumJerk(std::min((s - lift_at) / spec_.down_s, 1.0)));
  }
  return last_;
}

}  // namespace mrsns::simulation
