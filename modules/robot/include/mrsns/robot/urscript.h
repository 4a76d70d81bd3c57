#pragma once
// URScript motion commands as sent to the secondary (30002) or real-time (30003) script interface of a UR
// controller, one line each, in UR units (metres, radians, seconds; poses as p[x, y, z, rx, ry, rz] with a
// rotation vector). The workstation works in millimetres: the conversion happens here and only here. Numbers are
// written with the shortest representation that reads back exactly, so a parsed line equals what was sent.
// The parser is the simulator's side: it accepts the same commands and throws FormatError on anything else.
#include <Eigen/Geometry>
#include <array>
#include <string>
#include <string_view>

#include "mrsns/robot/robot_arm.h"

namespace mrsns::robot::urscript {

struct ServoJOptions {
  double time_s = 0.008;          // how long the target is held (one control period)
  double lookahead_time_s = 0.1;  // 0.03..0.2: smooths the trajectory
  double gain = 300;              // 100..2000: proportional gain
};

/// "servoj([q1, ..., q6], 0, 0, t, lookahead, gain)" (acceleration and speed are unused by the controller).
std::string servoj(const Joints& q, const ServoJOptions& options = {});
/// "speedl([vx, vy, vz, wx, wy, wz], a, t)": twist in mm/s and rad/s, acceleration in mm/s^2, t in s.
std::string speedl(const Twist& twist, double acceleration_mm_s2, double time_s);
/// "movel(p[...], a=..., v=...)": target flange/TCP pose in the base frame, mm.
std::string movel(const Eigen::Isometry3d& base_T_tcp, double acceleration_mm_s2, double speed_mm_s);
/// "movej([q...], a=..., v=...)".
std::string movej(const Joints& q, double acceleration_rad_s2, double speed_rad_s);
/// "stopj(a)": decelerate joints at a rad/s^2.
std::string stopj(double deceleration_rad_s2);
/// "stopl(a)": decelerate the tool at a mm/s^2.
std::string stopl(double deceleration_mm_s2);

/// "protective_stop()": the controller raises a protective stop (URScript, PolyScope 5); unlock via dashboard.
std::string protectiveStop();

/// UR pose vector [x, y, z (m), rotation vector (rad)] <-> isometry in mm.
std::array<double, 6> toUrPose(const Eigen::Isometry3d& base_T_tcp);
Eigen::Isometry3d fromUrPose(const std::array<double, 6>& pose);

enum class CommandKind { ServoJ, SpeedL, MoveL, MoveJ, StopJ, StopL, ProtectiveStop };

/// One parsed command in workstation units (mm, rad, s).
struct Command {
  CommandKind kind = CommandKind::StopJ;
  Joints q = Joints::Zero();                               // servoj, movej
  Twist twist = Twist::Zero();                             // speedl (mm/s, rad/s)
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();  // movel (mm)
  double acceleration = 0;                                 // stopj/movej rad/s^2; speedl/movel/stopl mm/s^2
  double speed = 0;                                        // movej rad/s; movel mm/s
  double time_s = 0;                                       // servoj t, speedl t
  double lookahead_time_s = 0.1, gain = 300;
};

/// Parses one line (trailing newline and blanks ignored; keyword arguments a=, v=, t=, lookahead_time=, gain=
/// accepted). Throws FormatError naming what is wrong for other functions, wrong argument counts, non-finite
/// numbers.
Command parseLine(std::string_view line);

}  // namespace mrsns::robot::urscript
