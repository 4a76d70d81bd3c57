#include "mrsns/robot/urscript.h"

#include <charconv>
#include <cmath>
#include <map>
#include <optional>
#include <vector>

#include "mrsns/core/error.h"
#include "mrsns/core/rigid.h"

namespace mrsns::robot::urscript {
namespace {

constexpr double kMmPerM = 1000.0;

std::string num(double v) {
  if (!std::isfinite(v)) {
    throw InvalidArgumentError("URScript: a command argument is not finite (NaN or infinity); refusing to send it");
  }
  char buf[32];
  const auto r = std::to_chars(buf, buf + sizeof buf, v);
  return std::string(buf, r.ptr);
}

template <typename Vec>
std::string list(const Vec& v, std::size_t n, double scale_first3 = 1.0) {
  std::string out = "[";
  for (std::size_t i = 0; i < n; ++i) {
    if (i) out += ", ";
    out += num(i < 3 ? v[i] * scale_first3 : v[i]);
  }
  return out + "]";
}

std::string_view trim(std::string_view s) {
  while (!s.empty() && std::isspace(static_cast<unsigned char>(s.front()))) s.remove_prefix(1);
  while (!s.empty() && std::isspace(static_cast<unsigned char>(s.back()))) s.remove_suffix(1);
  return s;
}

[[noreturn]] void bad(std::string_view line, const std::string& what) {
  throw FormatError("URScript line '" + std::string(line.substr(0, 120)) + "': " + what);
}

struct Arg {
  std::string keyword;         // empty when positional
  bool is_pose = false;        // p[...]
  std::vector<double> values;  // one for a number, n for a list
  bool is_list = false;
};

double parseNumber(std::string_view line, std::string_view s) {
  s = trim(s);
  if (!s.empty() && s.front() == '+') s.remove_prefix(1);
  double v = 0;
  const auto r = std::from_chars(s.data(), s.data() + s.size(), v);
  if (s.empty() || r.ec != std::errc() || r.ptr != s.data() + s.size() || !std::isfinite(v)) {
    bad(line, "'" + std::string(s) + "' is not a finite number");
  }
  return v;
}

std::vector<Arg> splitArgs(std::string_view line, std::string_view inner) {
  std::vector<Arg> args;
  if (trim(inner).empty()) return args;
  std::vector<std::string_view> parts;
  int depth = 0;
  std::size_t start = 0;
  for (std::size_t i = 0; i < inner.size(); ++i) {
    if (inner[i] == '[') ++depth;
    if (inner[i] == ']' && --depth < 0) bad(line, "unbalanced ']'");
    if (inner[i] == ',' && depth == 0) {
      parts.push_back(inner.substr(start, i - start));
      start = i + 1;
    }
  }
  if (depth != 0) bad(line, "unbalanced '['");
  parts.push_back(inner.substr(start));
  for (auto part : parts) {
    part = trim(part);
    Arg a;
    const auto eq = part.find('=');
    if (eq != std::string_view::npos && part.find('[') > eq) {
      a.keyword = std::string(trim(part.substr(0, eq)));
      part = trim(part.substr(eq + 1));
    }
    if (part.starts_with("p[")) {
      a.is_pose = true;
      part.remove_prefix(1);
    }
    if (part.starts_with('[')) {
      if (!part.ends_with(']')) bad(line, "list argument does not end with ']'");
      a.is_list = true;
      auto body = part.substr(1, part.size() - 2);
      std::size_t s = 0;
      while (s <= body.size()) {
        const auto comma = body.find(',', s);
        a.values.push_back(parseNumber(line, body.substr(s, comma == std::string_view::npos ? body.npos : comma - s)));
        if (comma == std::string_view::npos) break;
        s = comma + 1;
      }
    } else {
      a.values.push_back(parseNumber(line, part));
    }
    args.push_back(std::move(a));
  }
  return args;
}

// Maps positional and keyword arguments onto the function's parameter names.
std::map<std::string, Arg> bind(std::string_view line, std::vector<Arg> args, const std::vector<std::string>& params,
                                std::size_t required) {
  std::map<std::string, Arg> out;
  bool keyword_seen = false;
  for (std::size_t i = 0; i < args.size(); ++i) {
    std::string name;
    if (args[i].keyword.empty()) {
      if (keyword_seen) bad(line, "positional argument after a keyword argument");
      if (i >= params.size()) bad(line, "too many arguments (at most " + std::to_string(params.size()) + ")");
      name = params[i];
    } else {
      keyword_seen = true;
      name = args[i].keyword;
      if (std::find(params.begin(), params.end(), name) == params.end()) bad(line, "unknown argument '" + name + "'");
    }
    if (out.count(name)) bad(line, "argument '" + name + "' given twice");
    out[name] = std::move(args[i]);
  }
  for (std::size_t i = 0; i < required; ++i) {
    if (!out.count(params[i])) bad(line, "missing argument '" + params[i] + "'");
  }
  return out;
}

double scalar(std::string_view line, const std::map<std::string, Arg>& args, const std::string& name, double fallback) {
  const auto it = args.find(name);
  if (it == args.end()) return fallback;
  if (it->second.is_list) bad(line, "argument '" + name + "' must be a number, not a list");
  return it->second.values[0];
}

std::array<double, 6> vector6(std::string_view line, const std::map<std::string, Arg>& args, const std::string& name,
                              bool pose) {
  const auto& a = args.at(name);
  if (!a.is_list || a.values.size() != 6) bad(line, "argument '" + name + "' must be a list of 6 numbers");
  if (pose && !a.is_pose) bad(line, "argument '" + name + "' must be a pose p[x, y, z, rx, ry, rz]");
  if (!pose && a.is_pose) bad(line, "argument '" + name + "' must be a joint or speed list, not a pose");
  std::array<double, 6> v{};
  std::copy(a.values.begin(), a.values.end(), v.begin());
  return v;
}

Joints joints(const std::array<double, 6>& v) {
  return Joints(v.data());
}

}  // namespace

std::string servoj(const Joints& q, const ServoJOptions& o) {
  return "servoj(" + list(q, 6) + ", 0, 0, " + num(o.time_s) + ", " + num(o.lookahead_time_s) + ", " + num(o.gain) +
         ")";
}

std::string speedl(const Twist& twist, double acceleration_mm_s2, double time_s) {
  return "speedl(" + list(twist, 6, 1.0 / kMmPerM) + ", " + num(acceleration_mm_s2 / kMmPerM) + ", " + num(time_s) +
         ")";
}

std::string movel(const Eigen::Isometry3d& base_T_tcp, double acceleration_mm_s2, double speed_mm_s) {
  return "movel(p" + list(toUrPose(base_T_tcp), 6) + ", a=" + num(acceleration_mm_s2 / kMmPerM) +
         ", v=" + num(speed_mm_s / kMmPerM) + ")";
}

std::string movej(const Joints& q, double acceleration_rad_s2, double speed_rad_s) {
  return "movej(" + list(q, 6) + ", a=" + num(acceleration_rad_s2) + ", v=" + num(speed_rad_s) + ")";
}

std::string stopj(double deceleration_rad_s2) {
  return "stopj(" + num(deceleration_rad_s2) + ")";
}
std::string stopl(double deceleration_mm_s2) {
  return "stopl(" + num(deceleration_mm_s2 / kMmPerM) + ")";
}

std::string protectiveStop() {
  return "protective_stop()";
}

std::array<double, 6> toUrPose(const Eigen::Isometry3d& T) {
  const Eigen::Vector3d rv = so3Log(T.linear());
  return {T.translation().x() / kMmPerM,
          T.translation().y() / kMmPerM,
          T.translation().z() / kMmPerM,
          rv.x(),
          rv.y(),
          rv.z()};
}

Eigen::Isometry3d fromUrPose(const std::array<double, 6>& p) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = so3Exp(Eigen::Vector3d(p[3], p[4], p[5]));
  T.translation() = Eigen::Vector3d(p[0], p[1], p[2]) * kMmPerM;
  return T;
}

Command parseLine(std::string_view raw) {
  const auto line = trim(raw);
  const auto open = line.find('(');
  if (open == std::string_view::npos || !line.ends_with(')')) {
    bad(line, "expected one call 'name(arguments)' (servoj, speedl, movel, movej, stopj or stopl)");
  }
  const auto name = trim(line.substr(0, open));
  auto args = splitArgs(line, line.substr(open + 1, line.size() - open - 2));
  Command c;
  if (name == "servoj") {
    const auto b = bind(line, std::move(args), {"q", "a", "v", "t", "lookahead_time", "gain"}, 1);
    c.kind = CommandKind::ServoJ;
    c.q = joints(vector6(line, b, "q", false));
    c.time_s = scalar(line, b, "t", 0.002);
    c.lookahead_time_s = scalar(line, b, "lookahead_time", 0.1);
    c.gain = scalar(line, b, "gain", 300);
  } else if (name == "speedl") {
    const auto b = bind(line, std::move(args), {"xd", "a", "t", "aRot"}, 2);
    c.kind = CommandKind::SpeedL;
    const auto v = vector6(line, b, "xd", false);
    c.twist << v[0] * kMmPerM, v[1] * kMmPerM, v[2] * kMmPerM, v[3], v[4], v[5];
    c.acceleration = scalar(line, b, "a", 0) * kMmPerM;
    c.time_s = scalar(line, b, "t", 0);
  } else if (name == "movel") {
    const auto b = bind(line, std::move(args), {"pose", "a", "v", "t", "r"}, 1);
    c.kind = CommandKind::MoveL;
    c.pose = fromUrPose(vector6(line, b, "pose", true));
    c.acceleration = scalar(line, b, "a", 1.2) * kMmPerM;
    c.speed = scalar(line, b, "v", 0.25) * kMmPerM;
  } else if (name == "movej") {
    const auto b = bind(line, std::move(args), {"q", "a", "v", "t", "r"}, 1);
    c.kind = CommandKind::MoveJ;
    c.q = joints(vector6(line, b, "q", false));
    c.acceleration = scalar(line, b, "a", 1.4);
    c.speed = scalar(line, b, "v", 1.05);
  } else if (name == "stopj") {
    const auto b = bind(line, std::move(args), {"a"}, 1);
    c.kind = CommandKind::StopJ;
    c.acceleration = scalar(line, b, "a", 0);
  } else if (name == "stopl") {
    const auto b = bind(line, std::move(args), {"a", "aRot"}, 1);
    c.kind = CommandKind::StopL;
    c.acceleration = scalar(line, b, "a", 0) * kMmPerM;
  } else if (name == "protective_stop") {
    (void)bind(line, std::move(args), {}, 0);
    c.kind = CommandKind::ProtectiveStop;
  } else {
    bad(line, "unsupported function '" + std::string(name) +
                  "' (the MR-SNS UR simulator accepts servoj, speedl, movel, movej, stopj, stopl, protective_stop)");
  }
  if (c.acceleration < 0 || c.speed < 0 || c.time_s < 0) bad(line, "accelerations, speeds and times must be >= 0");
  return c;
}

}  // namespace mrsns::robot::urscript
