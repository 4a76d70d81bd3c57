// Scenario JSON -> Scenario, strictly: every object's keys are checked
// against the keys its reader knows, and errors name the key path.
#include "mrsns/simulation/scenario.h"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <initializer_list>
#include <nlohmann/json.hpp>
#include <set>
#include <sstream>

#include "mrsns/core/data_dir.h"
#include "mrsns/core/error.h"
#include "mrsns/core/rigid.h"
#include "mrsns/core/units.h"

namespace mrsns::simulation {

namespace {

using Json = nlohmann::json;

// One JSON object being read: remembers its key path for messages and refuses
// keys that no reader asked for.
class Node {
 public:
  Node(const Json& json, std::string path, std::string source)
      : json_(json), path_(std::move(path)), source_(std::move(source)) {
    if (!json_.is_object()) fail("must be an object");
  }

  void allow(std::initializer_list<const char*> keys) const {
    std::set<std::string> known(keys.begin(), keys.end());
    for (const auto& [key, value] : json_.items()) {
      if (!known.count(key)) {
        std::string list;
        for (const auto& k : known) list += (list.empty() ? "" : ", ") + k;
        throw FormatError(source_ + ": unknown key '" + at(key) + "' (known here: " + list + ")");
      }
    }
  }

  [[nodiscard]] bool has(const char* key) const { return json_.contains(key); }
  [[nodiscard]] std::string at(const std::string& key) const { return path_.empty() ? key : path_ + "." + key; }

  [[noreturn]] void fail(const std::string& what) const {
    throw FormatError(source_ + ": " + (path_.empty() ? "the scenario" : "'" + path_ + "'") + " " + what);
  }
  [[noreturn]] void failKey(const std::string& key, const std::string& what) const {
    throw FormatError(source_ + ": '" + at(key) + "' " + what);
  }

  Node child(const char* key) const { return Node(json_.at(key), at(key), source_); }
  std::vector<Node> array(const char* key) const {
    std::vector<Node> out;
    if (!has(key)) return out;
    const auto& a = json_.at(key);
    if (!a.is_array()) failKey(key, "must be an array");
    for (std::size_t i = 0; i < a.size(); ++i) out.emplace_back(a[i], at(key) + "[" + std::to_string(i) + "]", source_);
    return out;
  }

  double number(const char* key, double fallback, double lo = -INFINITY, double hi = INFINITY) const {
    if (!has(key)) return fallback;
    const auto& v = json_.at(key);
    if (!v.is_number()) failKey(key, "must be a number");
    const double x = v.get<double>();
    if (!std::isfinite(x) || x < lo || x > hi) {
      std::ostringstream s;
      s << "is " << x << ", outside [" << lo << ", " << hi << "]";
      failKey(key, s.str());
    }
    return x;
  }
  int integer(const char* key, int fallback, int lo, int hi) const {
    if (!has(key)) return fallback;
    const auto& v = json_.at(key);
    if (!v.is_number_integer()) failKey(key, "must be an integer");
    const auto x = v.get<long long>();
    if (x < lo || x > hi)
      failKey(key, "is " + std::to_string(x) + ", outside [" + std::to_string(lo) + ", " + std::to_string(hi) + "]");
    return static_cast<int>(x);
  }
  bool boolean(const char* key, bool fallback) const {
    if (!has(key)) return fallback;
    if (!json_.at(key).is_boolean()) failKey(key, "must be true or false");
    return json_.at(key).get<bool>();
  }
  std::string text(const char* key, const std::string& fallback) const {
    if (!has(key)) return fallback;
    if (!json_.at(key).is_string()) failKey(key, "must be a string");
    return json_.at(key).get<std::string>();
  }
  std::string required(const char* key) const {
    if (!has(key)) fail("needs '" + std::string(key) + "'");
    return text(key, "");
  }
  Eigen::Vector3d vector3(const char* key, const Eigen::Vector3d& fallback) const {
    if (!has(key)) return fallback;
    const auto& v = json_.at(key);
    if (!v.is_array() || v.size() != 3) failKey(key, "must be an array of 3 numbers");
    Eigen::Vector3d out;
    for (int i = 0; i < 3; ++i) {
      if (!v[static_cast<std::size_t>(i)].is_number()) failKey(key, "must be an array of 3 numbers");
      out[i] = v[static_cast<std::size_t>(i)].get<double>();
    }
    if (!out.allFinite()) failKey(key, "must be finite");
    return out;
  }
  /// A range [low, high] of two numbers within [lo, hi], low <= high.
  std::array<double, 2> range(const char* key, std::array<double, 2> fallback, double lo, double hi) const {
    if (!has(key)) return fallback;
    const auto& v = json_.at(key);
    if (!v.is_array() || v.size() != 2 || !v[0].is_number() || !v[1].is_number()) {
      failKey(key, "must be [low, high]");
    }
    const std::array<double, 2> out{v[0].get<double>(), v[1].get<double>()};
    if (!std::isfinite(out[0]) || !std::isfinite(out[1]) || out[0] < lo || out[1] > hi || out[0] > out[1]) {
      std::ostringstream s;
      s << "must be [low, high] with " << lo << " <= low <= high <= " << hi;
      failKey(key, s.str());
    }
    return out;
  }
  std::vector<int> integers(const char* key) const {
    std::vector<int> out;
    if (!has(key)) return out;
    const auto& v = json_.at(key);
    if (!v.is_array()) failKey(key, "must be an array of integers");
    for (const auto& x : v) {
      if (!x.is_number_integer()) failKey(key, "must be an array of integers");
      out.push_back(x.get<int>());
    }
    return out;
  }
  /// A pose: {"translation_mm": [x,y,z], "rotation_deg": [rx,ry,rz]} (rotation vector, degrees) or
  /// {"matrix": [16 numbers, row-major]}.
  Eigen::Isometry3d pose(const char* key, const Eigen::Isometry3d& fallback) const {
    if (!has(key)) return fallback;
    const Node p = child(key);
    p.allow({"translation_mm", "rotation_deg", "matrix"});
    if (p.has("matrix")) {
      if (p.has("translation_mm") || p.has("rotation_deg")) p.fail("gives both a matrix and translation/rotation");
      const auto& m = p.json_.at("matrix");
      if (!m.is_array() || m.size() != 16) p.failKey("matrix", "must be 16 numbers (row-major 4x4)");
      std::array<double, 16> values{};
      for (std::size_t i = 0; i < 16; ++i) {
        if (!m[i].is_number()) p.failKey("matrix", "must be 16 numbers (row-major 4x4)");
        values[i] = m[i].get<double>();
      }
      try {
        return isometryFromRowMajor(values, 1e-4);
      } catch (const Error& e) {
        p.failKey("matrix", std::string("is not a rigid transform: ") + e.what());
      }
    }
    Eigen::Isometry3d out = Eigen::Isometry3d::Identity();
    out.translation() = p.vector3("translation_mm", Eigen::Vector3d::Zero());
    out.linear() = so3Exp(p.vector3("rotation_deg", Eigen::Vector3d::Zero()) * kDeg);
    return out;
  }

  [[nodiscard]] const Json& json() const { return json_; }

 private:
  const Json& json_;
  std::string path_;
  std::string source_;
};

template <typename E>
E choose(const Node& n, const char* key, E fallback, std::initializer_list<std::pair<const char*, E>> options) {
  if (!n.has(key)) return fallback;
  const std::string value = n.text(key, "");
  std::string list;
  for (const auto& [name, e] : options) {
    if (value == name) return e;
    list += (list.empty() ? "" : ", ") + std::string(name);
  }
  n.failKey(key, "is '" + value + "'; use one of " + list);
}

PoseFrame poseFrame(const Node& n, const char* key) {
  return choose<PoseFrame>(n, key, PoseFrame::Tracker,
                           {{"Tracker", PoseFrame::Tracker},
                            {"Reference", PoseFrame::Reference},
                            {"Phantom", PoseFrame::Phantom},
                            {"CT", PoseFrame::CT},
                            {"RobotBase", PoseFrame::RobotBase}});
}

std::filesystem::path filePath(const Node& n, const char* key, const std::filesystem::path& base) {
  const std::string text = n.required(key);
  std::filesystem::path p = text;
  if (text.rfind("data:", 0) == 0) {
    p = dataDirectory() / text.substr(5);
  } else if (p.is_relative()) {
    p = base / p;
  }
  if (!std::filesystem::exists(p)) {
    throw FileError("'" + n.at(key) + "': " + p.string() + " does not exist");
  }
  return p;
}

CubeOperatorSpec readCubeOperator(const Node& n) {
  n.allow({"enabled", "tool", "hologram", "prompt_contains", "confirm", "confirm_on_headset", "align_s",
           "confirm_after_s", "hold_s", "views", "depth_bias_mm", "depth_error_mm", "lateral_error_mm",
           "rotation_deg", "tremor_mm", "tremor_hz",
           "tremor_rotation_deg", "drift_mm_per_s", "jerks_per_s", "jerk_mm", "jerk_duration_s"});
  CubeOperatorSpec c;
  c.enabled = n.boolean("enabled", true);
  c.tool = n.text("tool", c.tool);
  c.hologram = n.text("hologram", c.hologram);
  c.prompt_contains = n.text("prompt_contains", c.prompt_contains);
  c.confirm = n.text("confirm", c.confirm);
  c.confirm_on_headset = n.boolean("confirm_on_headset", c.confirm_on_headset);
  if (c.hologram.empty() || c.prompt_contains.empty() || c.confirm.empty()) {
    n.fail("needs a non-empty hologram, prompt_contains and confirm");
  }
  c.align_s = n.number("align_s", c.align_s, 0.1, 600.0);
  c.confirm_after_s = n.number("confirm_after_s", c.confirm_after_s, 0.0, 600.0);
  c.hold_s = n.number("hold_s", c.hold_s, 0.1, 600.0);
  for (const auto& v : n.array("views")) {
    v.allow({"name", "eye_from_cube_mm"});
    CubeView view;
    view.name = v.required("name");
    view.eye_from_cube_mm = v.vector3("eye_from_cube_mm", view.eye_from_cube_mm);
    if (view.name.empty() || view.eye_from_cube_mm.norm() < 100.0) {
      v.fail("needs a name and eyes at least 100 mm from the cube");
    }
    c.views.push_back(view);
  }
  if (c.views.empty()) {
    // Paper 001's four views around a cube held in front of the tracker (the camera looks along -z).
    c.views = {{"front", {0.0, -350.0, 350.0}},
               {"left", {-450.0, 0.0, 250.0}},
               {"right", {450.0, 0.0, 250.0}},
               {"ground", {0.0, 0.0, 500.0}}};
  }
  c.depth_bias_mm = n.number("depth_bias_mm", c.depth_bias_mm, -50.0, 50.0);
  c.depth_error_mm = n.number("depth_error_mm", c.depth_error_mm, 0.0, 50.0);
  c.lateral_error_mm = n.number("lateral_error_mm", c.lateral_error_mm, 0.0, 50.0);
  c.rotation_deg = n.number("rotation_deg", c.rotation_deg, 0.0, 20.0);
  c.tremor_mm = n.number("tremor_mm", c.tremor_mm, 0.0, 20.0);
  const auto range = n.range("tremor_hz", {c.tremor_min_hz, c.tremor_max_hz}, 0.1, 60.0);
  c.tremor_min_hz = range[0];
  c.tremor_max_hz = range[1];
  c.tremor_rotation_deg = n.number("tremor_rotation_deg", c.tremor_rotation_deg, 0.0, 10.0);
  c.drift_mm_per_s = n.number("drift_mm_per_s", c.drift_mm_per_s, 0.0, 100.0);
  c.jerks_per_s = n.number("jerks_per_s", c.jerks_per_s, 0.0, 50.0);
  const auto jerk = n.range("jerk_mm", {c.jerk_min_mm, c.jerk_max_mm}, 0.0, 100.0);
  c.jerk_min_mm = jerk[0];
  c.jerk_max_mm = jerk[1];
  c.jerk_duration_s = n.number("jerk_duration_s", c.jerk_duration_s, 0.001, 5.0);
  return c;
}

void checkToolName(const Node& n, const char* key, const std::string& name) {
  const auto to = name.find("To");
  if (name.empty() || to == std::string::npos || to == 0 || to + 2 >= name.size() || name.size() > 20) {
    n.failKey(key, "'" + name + "' is not a PLUS transform name of at most 20 characters (e.g. StylusToTracker)");
  }
}

HeadsetCameraSpec readHeadsetCamera(const Node& n) {
  n.allow({"enabled", "camera_to_marker", "fx", "fy", "cx", "cy", "distortion", "width", "height", "send_intrinsics",
           "intrinsics_focal_error_percent", "intrinsics_principal_error_px", "board_tool", "rows", "cols",
           "square_mm", "grid_to_board", "prompt_contains", "move_s", "settle_s", "distance_mm", "max_tilt_deg",
           "max_roll_deg", "head_sway_mm", "blur_sigma_px", "noise_sigma"});
  HeadsetCameraSpec c;
  c.enabled = n.boolean("enabled", true);
  c.marker_T_camera = n.pose("camera_to_marker", c.marker_T_camera);
  c.width = static_cast<int>(n.integer("width", c.width, 64, 4096));
  c.height = static_cast<int>(n.integer("height", c.height, 64, 4096));
  c.fx = n.number("fx", c.fx, 50.0, 20000.0);
  c.fy = n.number("fy", c.fy, 50.0, 20000.0);
  c.cx = n.number("cx", 0.5 * c.width, 0.0, c.width);
  c.cy = n.number("cy", 0.5 * c.height, 0.0, c.height);
  if (n.has("distortion")) {
    const auto& d = n.json().at("distortion");
    if (!d.is_array() || d.size() != 5) n.failKey("distortion", "must be [k1, k2, p1, p2, k3]");
    for (std::size_t i = 0; i < 5; ++i) {
      if (!d[i].is_number() || !(std::abs(d[i].get<double>()) <= 2.0)) {
        n.failKey("distortion", "must be 5 numbers within [-2, 2]");
      }
      c.distortion[i] = d[i].get<double>();
    }
  }
  c.send_intrinsics = n.boolean("send_intrinsics", c.send_intrinsics);
  c.intrinsics_focal_error_percent =
      n.number("intrinsics_focal_error_percent", c.intrinsics_focal_error_percent, 0.0, 20.0);
  c.intrinsics_principal_error_px = n.number("intrinsics_principal_error_px", c.intrinsics_principal_error_px, 0.0, 100.0);
  c.board_tool = n.text("board_tool", c.board_tool);
  checkToolName(n, "board_tool", c.board_tool);
  c.rows = static_cast<int>(n.integer("rows", c.rows, 2, 30));
  c.cols = static_cast<int>(n.integer("cols", c.cols, 2, 30));
  c.square_mm = n.number("square_mm", c.square_mm, 2.0, 500.0);
  c.board_T_grid = n.pose("grid_to_board", c.board_T_grid);
  c.prompt_contains = n.text("prompt_contains", c.prompt_contains);
  if (c.prompt_contains.empty()) n.failKey("prompt_contains", "must not be empty");
  c.move_s = n.number("move_s", c.move_s, 0.1, 60.0);
  c.settle_s = n.number("settle_s", c.settle_s, 0.1, 60.0);
  const auto d = n.range("distance_mm", {c.min_distance_mm, c.max_distance_mm}, 100.0, 5000.0);
  c.min_distance_mm = d[0];
  c.max_distance_mm = d[1];
  c.max_tilt_deg = n.number("max_tilt_deg", c.max_tilt_deg, 0.0, 70.0);
  c.max_roll_deg = n.number("max_roll_deg", c.max_roll_deg, 0.0, 180.0);
  c.head_sway_mm = n.number("head_sway_mm", c.head_sway_mm, 0.0, 50.0);
  c.blur_sigma_px = n.number("blur_sigma_px", c.blur_sigma_px, 0.0, 10.0);
  c.noise_sigma = n.number("noise_sigma", c.noise_sigma, 0.0, 100.0);
  return c;
}

BoardTouchSpec readBoardTouch(const Node& n) {
  n.allow({"enabled", "tool", "prompt_contains", "travel_s", "down_s", "dwell_s", "approach_mm",
           "placement_error_mm", "tremor_mm", "misplaced"});
  BoardTouchSpec b;
  for (const auto& m : n.array("misplaced")) {
    m.allow({"corner", "offset_mm"});
    b.misplaced.push_back({m.integer("corner", 1, 1, 900), m.vector3("offset_mm", Eigen::Vector3d::Zero())});
  }
  b.enabled = n.boolean("enabled", true);
  b.tool = n.text("tool", b.tool);
  checkToolName(n, "tool", b.tool);
  b.prompt_contains = n.text("prompt_contains", b.prompt_contains);
  if (b.prompt_contains.empty()) n.failKey("prompt_contains", "must not be empty");
  b.travel_s = n.number("travel_s", b.travel_s, 0.1, 60.0);
  b.down_s = n.number("down_s", b.down_s, 0.05, 10.0);
  b.dwell_s = n.number("dwell_s", b.dwell_s, 0.1, 60.0);
  b.approach_mm = n.number("approach_mm", b.approach_mm, 0.0, 500.0);
  b.placement_error_mm = n.number("placement_error_mm", b.placement_error_mm, 0.0, 20.0);
  b.tremor_mm = n.number("tremor_mm", b.tremor_mm, 0.0, 20.0);
  return b;
}

MotionSegment readSegment(const Node& n) {
  MotionSegment s;
  s.kind = choose<MotionKind>(n, "kind", MotionKind::Hold,
                              {{"hold", MotionKind::Hold},
                               {"move", MotionKind::Move},
                               {"sweep", MotionKind::Sweep},
                               {"pivot", MotionKind::Pivot},
                               {"spin", MotionKind::Spin},
                               {"up_down", MotionKind::UpDown},
                               {"touch_landmarks", MotionKind::TouchLandmarks},
                               {"trace_bone", MotionKind::TraceBone}});
  if (!n.has("kind")) n.fail("needs 'kind' (hold, move, sweep, pivot, spin, up_down, touch_landmarks, trace_bone)");
  s.duration_s = n.number("duration_s", 1.0, 1e-3, 86400.0);
  switch (s.kind) {
    case MotionKind::Hold: n.allow({"kind", "duration_s", "pose", "frame", "pose_of"}); break;
    case MotionKind::Move:
      n.allow({"kind", "duration_s", "pose", "frame", "pose_of"});
      if (!n.has("pose")) n.fail("(move) needs 'pose'");
      break;
    case MotionKind::Sweep:
      n.allow({"kind", "duration_s", "pose", "frame", "pose_of", "cycles"});
      if (!n.has("pose")) n.fail("(sweep) needs 'pose', the far end");
      s.cycles = n.integer("cycles", 1, 1, 10000);
      break;
    case MotionKind::Pivot:
      n.allow({"kind", "duration_s", "tip_mm", "amplitude_deg", "frequency_hz", "one_axis"});
      if (n.has("tip_mm")) s.tip_tool = n.vector3("tip_mm", Eigen::Vector3d::Zero());
      s.amplitude_deg = n.number("amplitude_deg", s.amplitude_deg, 0.0, 80.0);
      s.frequency_hz = n.number("frequency_hz", s.frequency_hz, 1e-3, 5.0);
      s.one_axis = n.boolean("one_axis", false);
      break;
    case MotionKind::Spin:
      // Turning the tool between the fingers about its shaft, the tip in the divot.
      n.allow({"kind", "duration_s", "amplitude_deg", "frequency_hz"});
      s.amplitude_deg = n.number("amplitude_deg", 60.0, 1.0, 170.0);
      s.frequency_hz = n.number("frequency_hz", s.frequency_hz, 1e-3, 5.0);
      break;
    case MotionKind::UpDown:
      n.allow({"kind", "duration_s", "amplitude_mm", "frequency_hz", "axis", "frame"});
      s.amplitude_mm = n.number("amplitude_mm", s.amplitude_mm, 0.0, 200.0);
      s.frequency_hz = n.number("frequency_hz", 0.5, 1e-3, 10.0);
      s.axis_tool = n.vector3("axis", s.axis_tool);
      if (s.axis_tool.norm() < 1e-9) n.failKey("axis", "must not be zero");
      s.axis_tool.normalize();
      break;
    case MotionKind::TouchLandmarks:
      n.allow({"kind", "frame", "points_mm", "points_ct_mm", "travel_s", "dwell_s", "approach_mm", "misplaced"});
      s.frame = n.has("frame") ? poseFrame(n, "frame") : PoseFrame::CT;
      if (s.frame != PoseFrame::CT && s.frame != PoseFrame::Phantom) {
        n.failKey("frame", "must be CT (the patient's fiducials) or Phantom (the N-wire phantom's landmarks)");
      }
      if (n.has("points_mm") && n.has("points_ct_mm")) n.fail("give points_mm or points_ct_mm, not both");
      // points_ct_mm: the name from before touch_landmarks had a frame; it is only for frame CT.
      if (n.has("points_ct_mm") && s.frame != PoseFrame::CT) n.failKey("points_ct_mm", "is for frame CT: use points_mm");
      for (const char* key : {"points_mm", "points_ct_mm"}) {
        if (!n.has(key)) continue;
        const auto& v = n.json().at(key);
        if (!v.is_array() || v.empty()) n.failKey(key, "must be a non-empty array of [x, y, z]");
        for (const auto& point : v) {
          Eigen::Vector3d q;
          const bool ok = point.is_array() && point.size() == 3 && point[0].is_number() && point[1].is_number() &&
                          point[2].is_number();
          if (ok) q = Eigen::Vector3d(point[0].get<double>(), point[1].get<double>(), point[2].get<double>());
          if (!ok || !q.allFinite()) n.failKey(key, "must be a non-empty array of [x, y, z] (mm)");
          s.points.push_back(q);
        }
      }
      s.travel_s = n.number("travel_s", s.travel_s, 0.1, 60.0);
      s.dwell_s = n.number("dwell_s", s.dwell_s, 0.1, 60.0);
      s.approach_mm = n.number("approach_mm", s.approach_mm, 0.0, 200.0);
      for (const auto& m : n.array("misplaced")) {
        m.allow({"landmark", "offset_mm"});
        MisplacedTouch t;
        t.landmark = m.integer("landmark", 0, 1, 1000);
        if (!m.has("landmark")) m.fail("needs 'landmark' (1-based, in the order touched)");
        t.offset = m.vector3("offset_mm", t.offset);
        s.misplaced.push_back(t);
      }
      // Its length follows from the landmarks (known once the patient is built).
      s.duration_s = 0.0;
      break;
    case MotionKind::TraceBone:
      n.allow({"kind", "duration_s", "points", "margin_mm"});
      s.trace_points = n.integer("points", s.trace_points, 4, 100000);
      s.trace_margin_mm = n.number("margin_mm", s.trace_margin_mm, 0.0, 200.0);
      break;
  }
  if (n.has("pose")) s.pose = n.pose("pose", Eigen::Isometry3d::Identity());
  if (s.kind != MotionKind::TouchLandmarks) s.frame = poseFrame(n, "frame");  // touch_landmarks: read above
  s.pose_of = choose<PoseOf>(n, "pose_of", PoseOf::Tool,
                             {{"tool", PoseOf::Tool}, {"image", PoseOf::Image}, {"tip", PoseOf::Tip}});
  return s;
}

HandModel readHand(const Node& n) {
  n.allow({"tremor_rms_mm", "tremor_hz", "tremor_rotation_rms_deg", "drift_mm", "drift_hz", "slips_per_min", "slip_mm",
           "dwell_jitter_s", "depth_misperception_mm"});
  HandModel h;
  h.tremor_rms_mm = n.number("tremor_rms_mm", 0.0, 0.0, 20.0);
  if (n.has("tremor_hz")) {
    const auto& v = n.json().at("tremor_hz");
    if (!v.is_array() || v.size() != 2 || !v[0].is_number() || !v[1].is_number()) {
      n.failKey("tremor_hz", "must be [min, max] in Hz");
    }
    h.tremor_min_hz = v[0].get<double>();
    h.tremor_max_hz = v[1].get<double>();
    if (!(h.tremor_min_hz > 0.0 && h.tremor_max_hz >= h.tremor_min_hz && h.tremor_max_hz < 100.0)) {
      n.failKey("tremor_hz", "must be 0 < min <= max < 100");
    }
  }
  h.tremor_rotation_rms_deg = n.number("tremor_rotation_rms_deg", 0.0, 0.0, 10.0);
  h.drift_mm = n.number("drift_mm", 0.0, 0.0, 100.0);
  h.drift_hz = n.number("drift_hz", h.drift_hz, 1e-4, 5.0);
  h.slips_per_min = n.number("slips_per_min", 0.0, 0.0, 600.0);
  h.slip_mm = n.number("slip_mm", h.slip_mm, 0.0, 100.0);
  h.dwell_jitter_s = n.number("dwell_jitter_s", 0.0, 0.0, 60.0);
  h.depth_misperception_mm = n.number("depth_misperception_mm", 0.0, 0.0, 50.0);
  return h;
}

ToolSpec readTool(const Node& n) {
  n.allow({"name", "marker_radius_mm", "start", "start_frame", "motion", "hand", "tip_mm", "shaft_axis"});
  ToolSpec t;
  t.name = n.required("name");
  checkToolName(n, "name", t.name);
  t.marker_radius_mm = n.number("marker_radius_mm", t.marker_radius_mm, 1.0, 500.0);
  t.start = n.pose("start", t.start);
  t.start_frame = poseFrame(n, "start_frame");
  for (const auto& s : n.array("motion")) t.motion.push_back(readSegment(s));
  if (n.has("hand")) t.hand = readHand(n.child("hand"));
  if (n.has("tip_mm")) t.tip_tool = n.vector3("tip_mm", Eigen::Vector3d::Zero());
  if (n.has("shaft_axis")) {
    const Eigen::Vector3d axis = n.vector3("shaft_axis", Eigen::Vector3d::UnitZ());
    if (axis.norm() < 1e-9) n.failKey("shaft_axis", "must not be zero");
    t.shaft_tool = axis.normalized();
    if (t.tip_tool && t.shaft_tool->dot(*t.tip_tool) <= 0.0) {
      n.failKey("shaft_axis", "must point from the marker towards the tip (its dot product with tip_mm is not "
                              "positive): the scorer compares directions");
    }
  }
  for (const auto& seg : t.motion) {
    if (seg.kind == MotionKind::Pivot && !seg.tip_tool && !t.tip_tool) {
      n.fail("pivots without a tip: give the tool's 'tip_mm' or the pivot segment's 'tip_mm'");
    }
    if (seg.kind == MotionKind::Spin && !t.tip_tool) n.fail("spins without a tip: give the tool's 'tip_mm'");
    const bool by_tip = seg.kind == MotionKind::TouchLandmarks || seg.kind == MotionKind::TraceBone ||
                        (seg.pose_of == PoseOf::Tip && seg.pose);
    if (by_tip && !t.tip_tool) n.fail("places its tip (touch_landmarks, trace_bone, pose_of tip) without 'tip_mm'");
  }
  return t;
}

TrackerSpec readTracker(const Node& n) {
  n.allow(
      {"bind", "port", "rate_hz", "max_header_version", "send_valid_transforms_only", "noise", "volume", "occluders"});
  TrackerSpec t;
  t.bind_address = n.text("bind", t.bind_address);
  t.port = static_cast<std::uint16_t>(n.integer("port", t.port, 0, 65535));
  t.rate_hz = n.number("rate_hz", t.rate_hz, 1.0, 1000.0);
  t.max_header_version = n.integer("max_header_version", t.max_header_version, 1, 2);
  t.send_valid_transforms_only = n.boolean("send_valid_transforms_only", t.send_valid_transforms_only);
  if (n.has("noise")) {
    const Node noise = n.child("noise");
    noise.allow({"position_rms_mm", "orientation_rms_deg"});
    t.noise.position_rms_mm = noise.number("position_rms_mm", t.noise.position_rms_mm, 0.0, 50.0);
    t.noise.orientation_rms_deg = noise.number("orientation_rms_deg", t.noise.orientation_rms_deg, 0.0, 10.0);
  }
  if (n.has("volume")) {
    const Node v = n.child("volume");
    v.allow({"near_mm", "far_mm", "half_angle_x_deg", "half_angle_y_deg"});
    t.volume.near_mm = v.number("near_mm", t.volume.near_mm, 0.0, 1e5);
    t.volume.far_mm = v.number("far_mm", t.volume.far_mm, t.volume.near_mm, 1e5);
    t.volume.half_angle_x_deg = v.number("half_angle_x_deg", t.volume.half_angle_x_deg, 1.0, 89.0);
    t.volume.half_angle_y_deg = v.number("half_angle_y_deg", t.volume.half_angle_y_deg, 1.0, 89.0);
  }
  for (const auto& o : n.array("occluders")) {
    o.allow({"center_mm", "radius_mm", "attached_to"});
    Occluder occ;
    occ.center = o.vector3("center_mm", occ.center);
    occ.radius_mm = o.number("radius_mm", occ.radius_mm, 1.0, 2000.0);
    occ.attached_to = o.text("attached_to", "");
    t.occluders.push_back(occ);
  }
  return t;
}

UltrasoundSpec readUltrasound(const Node& n) {
  n.allow({"enabled", "rate_hz", "width", "height", "spacing_mm", "probe_tool", "image_to_probe", "video_lag_s",
           "device_name", "attenuation_db_per_cm", "speckle"});
  UltrasoundSpec u;
  u.enabled = n.boolean("enabled", true);
  u.rate_hz = n.number("rate_hz", u.rate_hz, 1.0, 120.0);
  u.width = n.integer("width", u.width, 16, 2048);
  u.height = n.integer("height", u.height, 16, 2048);
  if (n.has("spacing_mm")) {
    const auto& v = n.json().at("spacing_mm");
    if (!v.is_array() || v.size() != 2 || !v[0].is_number() || !v[1].is_number() || v[0].get<double>() <= 0.0 ||
        v[1].get<double>() <= 0.0) {
      n.failKey("spacing_mm", "must be [x, y], both positive");
    }
    u.spacing_x_mm = v[0].get<double>();
    u.spacing_y_mm = v[1].get<double>();
  }
  u.probe_tool = n.text("probe_tool", u.probe_tool);
  checkToolName(n, "probe_tool", u.probe_tool);
  u.probe_T_image = n.pose("image_to_probe", u.probe_T_image);
  u.video_lag_s = n.number("video_lag_s", 0.0, -2.0, 2.0);
  u.device_name = n.text("device_name", u.device_name);
  if (u.device_name.empty() || u.device_name.size() > 20) n.failKey("device_name", "must be 1-20 characters");
  u.attenuation_db_per_cm = n.number("attenuation_db_per_cm", u.attenuation_db_per_cm, 0.0, 20.0);
  u.speckle = n.number("speckle", u.speckle, 0.0, 1.0);
  return u;
}

RobotSpec readRobot(const Node& n) {
  n.allow({"enabled", "ports", "base_to_tracker", "marker_to_flange", "drill_tip_mm", "marker_tool", "start_joints_deg",
           "hand_guided", "joint_limits_deg", "stops_lost"});
  RobotSpec r;
  r.enabled = n.boolean("enabled", true);
  if (n.has("ports")) {
    const Node p = n.child("ports");
    p.allow({"rtde", "dashboard", "secondary", "realtime"});
    r.rtde_port = static_cast<std::uint16_t>(p.integer("rtde", r.rtde_port, 0, 65535));
    r.dashboard_port = static_cast<std::uint16_t>(p.integer("dashboard", r.dashboard_port, 0, 65535));
    r.secondary_port = static_cast<std::uint16_t>(p.integer("secondary", r.secondary_port, 0, 65535));
    r.realtime_port = static_cast<std::uint16_t>(p.integer("realtime", r.realtime_port, 0, 65535));
  }
  r.tracker_T_base = n.pose("base_to_tracker", r.tracker_T_base);
  r.flange_T_marker = n.pose("marker_to_flange", r.flange_T_marker);
  r.drill_tip_flange = n.vector3("drill_tip_mm", r.drill_tip_flange);
  r.marker_tool = n.text("marker_tool", r.marker_tool);
  checkToolName(n, "marker_tool", r.marker_tool);
  if (n.has("start_joints_deg")) {
    const auto& v = n.json().at("start_joints_deg");
    if (!v.is_array() || v.size() != 6) n.failKey("start_joints_deg", "must be 6 numbers");
    for (std::size_t i = 0; i < 6; ++i) {
      if (!v[i].is_number()) n.failKey("start_joints_deg", "must be 6 numbers");
      r.start_joints[i] = v[i].get<double>() * kDeg;
    }
  }
  r.stops_lost = n.integer("stops_lost", 0, 0, 1000);
  if (n.has("joint_limits_deg")) {
    // {"<joint index 0-5>": [min, max]}: only the joints the safety configuration narrows.
    const auto& v = n.json().at("joint_limits_deg");
    if (!v.is_object()) n.failKey("joint_limits_deg", "must map joint indices (\"0\" to \"5\") to [min, max] degrees");
    for (const auto& [key, range] : v.items()) {
      const bool index_ok = key.size() == 1 && key[0] >= '0' && key[0] <= '5';
      const bool range_ok = range.is_array() && range.size() == 2 && range[0].is_number() && range[1].is_number() &&
                            range[0].get<double>() < range[1].get<double>();
      if (!index_ok || !range_ok) {
        n.failKey("joint_limits_deg", "must map joint indices (\"0\" to \"5\") to [min, max] degrees, min < max");
      }
      r.joint_limits[static_cast<std::size_t>(key[0] - '0')] =
          std::pair{range[0].get<double>() * kDeg, range[1].get<double>() * kDeg};
    }
  }
  for (const auto& w : n.array("hand_guided")) {
    w.allow({"at_s", "joints_deg", "pivot_drill", "spin_drill", "duration_s"});
    RobotSpec::GuidedWaypoint waypoint;
    if (w.has("at_s")) waypoint.at_s = w.number("at_s", 0.0, 0.0, 86400.0);
    if (static_cast<int>(w.has("joints_deg")) + static_cast<int>(w.has("pivot_drill")) +
            static_cast<int>(w.has("spin_drill")) != 1) {
      w.fail("needs exactly one of 'joints_deg' (6 numbers), 'pivot_drill' ({\"amplitude_deg\": 20, \"cycles\": 2}) "
             "or 'spin_drill' ({\"amplitude_deg\": 60, \"cycles\": 1})");
    }
    if (w.has("spin_drill")) {
      const Node spin = w.child("spin_drill");
      spin.allow({"amplitude_deg", "cycles"});
      waypoint.spin_deg = spin.number("amplitude_deg", 60.0, 1.0, 170.0);
      waypoint.spin_cycles = spin.integer("cycles", 1, 1, 100);
    } else if (w.has("pivot_drill")) {
      const Node pivot = w.child("pivot_drill");
      pivot.allow({"amplitude_deg", "cycles"});
      waypoint.pivot_deg = pivot.number("amplitude_deg", 20.0, 1.0, 45.0);
      waypoint.pivot_cycles = pivot.integer("cycles", 2, 1, 100);
    } else {
      const auto& v = w.json().at("joints_deg");
      if (!v.is_array() || v.size() != 6) w.failKey("joints_deg", "must be 6 numbers");
      for (std::size_t i = 0; i < 6; ++i) {
        if (!v[i].is_number()) w.failKey("joints_deg", "must be 6 numbers");
        waypoint.joints[i] = v[i].get<double>() * kDeg;
      }
    }
    waypoint.duration_s = w.number("duration_s", waypoint.duration_s, 0.05, 3600.0);
    r.hand_guided.push_back(waypoint);
  }
  return r;
}

Fault readFault(const Node& n) {
  Fault f;
  if (!n.has("kind")) n.fail("needs 'kind'");
  f.kind = choose<FaultKind>(n, "kind", FaultKind::Occlusion,
                             {{"occlusion", FaultKind::Occlusion},
                              {"tracker_disconnect", FaultKind::TrackerDisconnect},
                              {"patient_shift", FaultKind::PatientShift},
                              {"video_freeze", FaultKind::VideoFreeze},
                              {"robot_protective_stop", FaultKind::RobotProtectiveStop},
                              {"hmd_disconnect", FaultKind::HmdDisconnect}});
  f.at_s = n.number("at_s", 0.0, 0.0, 86400.0);
  switch (f.kind) {
    case FaultKind::Occlusion:
      n.allow({"kind", "at_s", "duration_s", "tool"});
      f.tool = n.required("tool");
      f.duration_s = n.number("duration_s", 1.0, 0.0, 86400.0);
      break;
    case FaultKind::TrackerDisconnect:
    case FaultKind::VideoFreeze:
    case FaultKind::HmdDisconnect:
      n.allow({"kind", "at_s", "duration_s"});
      f.duration_s = n.number("duration_s", 1.0, 0.0, 86400.0);
      break;
    case FaultKind::PatientShift:
      n.allow({"kind", "at_s", "shift", "relative_to_reference"});
      if (!n.has("shift")) n.fail("(patient_shift) needs 'shift' (a pose)");
      f.shift = n.pose("shift", f.shift);
      f.relative_to_reference = n.boolean("relative_to_reference", false);
      break;
    case FaultKind::RobotProtectiveStop: n.allow({"kind", "at_s"}); break;
  }
  return f;
}

}  // namespace

Scenario parseScenario(const std::string& json_text, const std::filesystem::path& base_dir, const std::string& source) {
  Json json;
  try {
    json = Json::parse(json_text);
  } catch (const Json::parse_error& e) {
    throw FormatError(source + ": not valid JSON (" + e.what() + ")");
  }
  const Node root(json, "", source);
  root.allow({"format", "name", "description", "seed", "duration_s", "tracker", "tools", "nwire_phantom", "patient",
              "flat_target", "ultrasound", "robot", "hmd", "faults", "replay"});
  const std::string format = root.required("format");
  if (format != "mrsns-scenario/1") {
    root.failKey("format", "is '" + format + "'; this mrsns-sim reads 'mrsns-scenario/1'");
  }
  Scenario s;
  s.source = source;
  s.name = root.text("name", s.name);
  (void)root.text("description", "");
  s.seed = static_cast<std::uint64_t>(root.integer("seed", 1, 0, 2147483647));
  s.duration_s = root.number("duration_s", 0.0, 0.0, 86400.0);
  if (root.has("tracker")) s.tracker = readTracker(root.child("tracker"));
  std::set<std::string> names;
  for (const auto& t : root.array("tools")) {
    s.tools.push_back(readTool(t));
    if (!names.insert(s.tools.back().name).second) t.failKey("name", "'" + s.tools.back().name + "' is used twice");
  }
  if (root.has("nwire_phantom")) {
    const Node n = root.child("nwire_phantom");
    n.allow({"config", "reference_tool", "phantom_to_reference", "wire_radius_mm", "bath_margin_mm"});
    NWirePhantomSpec p;
    p.config = filePath(n, "config", base_dir);
    p.reference_tool = n.text("reference_tool", p.reference_tool);
    checkToolName(n, "reference_tool", p.reference_tool);
    p.reference_T_phantom = n.pose("phantom_to_reference", p.reference_T_phantom);
    p.wire_radius_mm = n.number("wire_radius_mm", p.wire_radius_mm, 0.01, 5.0);
    p.bath_margin_mm = n.number("bath_margin_mm", p.bath_margin_mm, 0.0, 500.0);
    s.nwire_phantom = p;
  }
  if (root.has("patient")) {
    const Node n = root.child("patient");
    n.allow({"generated_phantom", "labels", "vessel_labels", "ignored_labels", "reference_tool", "ct_to_reference",
             "soft_tissue"});
    PatientSpec p;
    if (n.has("labels") == n.has("generated_phantom")) {
      n.fail("needs exactly one of 'generated_phantom' ({\"spacing_mm\": 0.8}) or 'labels' (a label map file)");
    }
    if (n.has("generated_phantom")) {
      const Node g = n.child("generated_phantom");
      g.allow({"spacing_mm"});
      p.generated = true;
      p.phantom_spacing_mm = g.number("spacing_mm", p.phantom_spacing_mm, 0.2, 3.0);
    } else {
      p.generated = false;
      p.labels = filePath(n, "labels", base_dir);
      p.vessel_labels = n.integers("vessel_labels");
      p.ignored_labels = n.integers("ignored_labels");
    }
    p.reference_tool = n.text("reference_tool", p.reference_tool);
    checkToolName(n, "reference_tool", p.reference_tool);
    p.reference_T_ct = n.pose("ct_to_reference", p.reference_T_ct);
    if (n.has("soft_tissue")) {
      const Node t = n.child("soft_tissue");
      t.allow({"shape_model", "model_to_ct", "modes", "amplitude_sd", "period_s", "push"});
      SoftTissueSpec tissue;
      tissue.shape_model = filePath(t, "shape_model", base_dir);
      tissue.ct_T_model = t.pose("model_to_ct", tissue.ct_T_model);
      tissue.modes = t.integer("modes", tissue.modes, 0, 1000);
      tissue.amplitude_sd = t.number("amplitude_sd", tissue.amplitude_sd, 0.0, 5.0);
      tissue.period_s = t.number("period_s", tissue.period_s, 0.1, 86400.0);
      if (t.has("push")) {
        const Node push = t.child("push");
        push.allow({"start_s", "ramp_s", "sd"});
        tissue.push_start_s = push.number("start_s", tissue.push_start_s, 0.0, 86400.0);
        tissue.push_ramp_s = push.number("ramp_s", tissue.push_ramp_s, 0.01, 3600.0);
        const auto& sd = push.json().contains("sd") ? push.json().at("sd") : Json();
        if (!sd.is_array() || sd.empty() || sd.size() > 1000) {
          push.failKey("sd", "must be an array of 1 to 1000 numbers (standard deviations per mode)");
        }
        for (const auto& v : sd) {
          if (!v.is_number() || !std::isfinite(v.get<double>()) || std::abs(v.get<double>()) > 5.0) {
            push.failKey("sd", "holds a value that is not a number in [-5, 5]");
          }
          tissue.push_sd.push_back(v.get<double>());
        }
      }
      p.soft_tissue = tissue;
    }
    s.patient = p;
  }
  if (root.has("flat_target")) {
    const Node n = root.child("flat_target");
    n.allow({"frame", "pose", "half_size_mm", "water_depth_mm"});
    FlatTargetSpec f;
    f.frame = poseFrame(n, "frame");
    f.pose = n.pose("pose", f.pose);
    if (n.has("half_size_mm")) {
      const auto& v = n.json().at("half_size_mm");
      if (!v.is_array() || v.size() != 2 || !v[0].is_number() || !v[1].is_number() || v[0].get<double>() <= 0.0 ||
          v[1].get<double>() <= 0.0) {
        n.failKey("half_size_mm", "must be [x, y], both positive");
      }
      f.half_size_mm = Eigen::Vector2d(v[0].get<double>(), v[1].get<double>());
    }
    f.water_depth_mm = n.number("water_depth_mm", f.water_depth_mm, 1.0, 1000.0);
    s.flat_target = f;
  }
  if (root.has("ultrasound")) s.ultrasound = readUltrasound(root.child("ultrasound"));
  if (root.has("robot")) s.robot = readRobot(root.child("robot"));
  if (root.has("hmd")) {
    const Node n = root.child("hmd");
    n.allow({"enabled", "host", "port", "unity", "drift_mm_per_min", "jitter_mm", "respond", "confirmations",
             "marker_tool", "world_to_marker", "cube", "camera", "board_touch"});
    s.hmd.marker_tool = n.text("marker_tool", "");
    if (!s.hmd.marker_tool.empty()) checkToolName(n, "marker_tool", s.hmd.marker_tool);
    s.hmd.marker_T_world = n.pose("world_to_marker", s.hmd.marker_T_world);
    for (const auto& r : n.array("respond")) {
      r.allow({"prompt_contains", "after_s", "confirm"});
      HmdResponse response;
      response.prompt_contains = r.required("prompt_contains");
      response.after_s = r.number("after_s", response.after_s, 0.0, 3600.0);
      response.confirm = r.required("confirm");
      if (response.confirm.empty() || response.prompt_contains.empty()) r.fail("needs a non-empty prompt and answer");
      s.hmd.responses.push_back(response);
    }
    for (const auto& c : n.array("confirmations")) {
      c.allow({"at_s", "confirm"});
      HmdConfirmation confirmation;
      confirmation.at_s = c.number("at_s", 0.0, 0.0, 86400.0);
      confirmation.confirm = c.required("confirm");
      if (confirmation.confirm.empty()) c.failKey("confirm", "must not be empty");
      s.hmd.confirmations.push_back(confirmation);
    }
    s.hmd.enabled = n.boolean("enabled", true);
    s.hmd.host = n.text("host", s.hmd.host);
    if (s.hmd.host.empty()) n.failKey("host", "must name the workstation's address");
    s.hmd.port = static_cast<std::uint16_t>(n.integer("port", s.hmd.port, 1, 65535));
    s.hmd.unity = n.boolean("unity", false);
    s.hmd.drift_mm_per_min = n.number("drift_mm_per_min", 0.0, 0.0, 1000.0);
    s.hmd.jitter_mm = n.number("jitter_mm", 0.0, 0.0, 100.0);
    if (n.has("cube")) {
      s.hmd.cube = readCubeOperator(n.child("cube"));
      if (!names.count(s.hmd.cube.tool)) {
        n.child("cube").failKey("tool", "'" + s.hmd.cube.tool + "' is not one of the scenario's tools");
      }
      if (s.hmd.marker_tool.empty()) {
        n.fail("has a cube operator but no marker_tool: the headset must be tracked to know where it shows the cube");
      }
    }
    if (n.has("camera")) {
      s.hmd.camera = readHeadsetCamera(n.child("camera"));
      if (!names.count(s.hmd.camera.board_tool)) {
        n.child("camera").failKey("board_tool", "'" + s.hmd.camera.board_tool + "' is not one of the scenario's tools");
      }
      if (s.hmd.marker_tool.empty()) {
        n.fail("has a camera but no marker_tool: the headset must be tracked for a hand-eye calibration");
      }
    }
    if (n.has("board_touch")) {
      s.hmd.board_touch = readBoardTouch(n.child("board_touch"));
      if (!s.hmd.camera.enabled) n.fail("has a board_touch but no camera: the board is the camera's");
      const auto tool = std::find_if(s.tools.begin(), s.tools.end(),
                                     [&](const ToolSpec& t) { return t.name == s.hmd.board_touch.tool; });
      if (tool == s.tools.end() || !tool->tip_tool) {
        n.child("board_touch").failKey("tool", "'" + s.hmd.board_touch.tool + "' is not a scenario tool with a tip_mm");
      }
    }
  }
  for (const auto& f : root.array("faults")) {
    s.faults.push_back(readFault(f));
    if (s.faults.back().kind == FaultKind::Occlusion && !names.count(s.faults.back().tool)) {
      f.failKey("tool", "'" + s.faults.back().tool + "' is not one of the scenario's tools");
    }
  }
  if (root.has("replay")) {
    const Node n = root.child("replay");
    n.allow({"sequence", "speed", "loop", "wait_for_client"});
    ReplaySpec r;
    r.sequence = filePath(n, "sequence", base_dir);
    r.speed = n.number("speed", 1.0, 0.01, 100.0);
    r.loop = n.boolean("loop", false);
    r.wait_for_client = n.boolean("wait_for_client", false);
    s.replay = r;
    if (!s.tools.empty() || s.ultrasound.enabled) {
      root.fail("replays a recording: 'tools' and 'ultrasound' come from the recording and must be left out");
    }
  }

  // Cross-checks: what a device needs must exist in the world.
  const auto needTool = [&](const std::string& name, const std::string& who) {
    if (!names.count(name)) {
      throw FormatError(source + ": " + who + " needs the tool '" + name + "', which 'tools' does not list");
    }
  };
  if (s.ultrasound.enabled) {
    needTool(s.ultrasound.probe_tool, "'ultrasound'");
    if (!s.nwire_phantom && !s.patient && !s.flat_target) {
      throw FormatError(source +
                        ": 'ultrasound' has nothing to image: add 'nwire_phantom', 'patient' or 'flat_target'");
    }
  }
  if (s.patient && !s.replay) needTool(s.patient->reference_tool, "'patient'");
  if (s.nwire_phantom && !s.replay) needTool(s.nwire_phantom->reference_tool, "'nwire_phantom'");
  if (s.hmd.enabled && !s.hmd.marker_tool.empty()) needTool(s.hmd.marker_tool, "'hmd'");
  if (s.robot.enabled && names.count(s.robot.marker_tool)) {
    throw FormatError(source + ": '" + s.robot.marker_tool +
                      "' is the robot's marker (robot.marker_tool): it moves with the arm, leave it out of 'tools'");
  }
  if (s.tools.empty() && !s.replay && !s.robot.enabled && !s.hmd.enabled) {
    throw FormatError(source + ": the scenario has no tools, no robot, no headset and no replay: nothing to serve");
  }
  return s;
}

Scenario readScenario(const std::filesystem::path& path) {
  std::ifstream in(path);
  if (!in) throw FileError("cannot read the scenario " + path.string() + " (does it exist?)");
  std::stringstream text;
  text << in.rdbuf();
  return parseScenario(text.str(), path.parent_path(), path.string());
}

const char* toString(FaultKind kind) {
  switch (kind) {
    case FaultKind::Occlusion: return "occlusion";
    case FaultKind::TrackerDisconnect: return "tracker_disconnect";
    case FaultKind::PatientShift: return "patient_shift";
    case FaultKind::VideoFreeze: return "video_freeze";
    case FaultKind::RobotProtectiveStop: return "robot_protective_stop";
    case FaultKind::HmdDisconnect: return "hmd_disconnect";
  }
  return "?";
}

const char* toString(PoseFrame frame) {
  switch (frame) {
    case PoseFrame::Tracker: return "Tracker";
    case PoseFrame::Reference: return "Reference";
    case PoseFrame::Phantom: return "Phantom";
    case PoseFrame::CT: return "CT";
    case PoseFrame::RobotBase: return "RobotBase";
  }
  return "?";
}

}  // namespace mrsns::simulation
