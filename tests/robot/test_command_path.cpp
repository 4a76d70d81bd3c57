// Only the workstation's control loop can command the arm. Link level: the tracking sources, the
// OpenIGTLink server/client and the hologram streamer (mrsns_tracking) do not link the robot library, so
// no network message handler can even name a RobotArm. API level: the loop holds the arm, is not
// copyable, and exposes only const views of its supervisor and guidance.
#include <gtest/gtest.h>

#include <string>
#include <type_traits>

#include "mrsns/robot/control_loop.h"

namespace mrsns::robot {
namespace {

#ifdef MRSNS_TRACKING_LINK_CLOSURE
TEST(CommandPath, StreamingAndTrackingLibrariesDoNotLinkTheRobot) {
  const std::string tracking = MRSNS_TRACKING_LINK_CLOSURE;
  const std::string igtlink = MRSNS_IGTLINK_LINK_CLOSURE;
  const std::string igtlink_net = MRSNS_IGTLINK_NET_LINK_CLOSURE;
  // Non-vacuous: the closures are real (they reach core) ...
  EXPECT_NE(tracking.find("core"), std::string::npos) << tracking;
  EXPECT_NE(igtlink_net.find("igtlink"), std::string::npos) << igtlink_net;
  // ... and none of them reaches the robot library.
  EXPECT_EQ(tracking.find("robot"), std::string::npos) << tracking;
  EXPECT_EQ(igtlink.find("robot"), std::string::npos) << igtlink;
  EXPECT_EQ(igtlink_net.find("robot"), std::string::npos) << igtlink_net;
}
#endif

TEST(CommandPath, TheControlLoopIsTheOnlyHolderOfTheArm) {
  static_assert(!std::is_copy_constructible_v<ControlLoop>);
  static_assert(!std::is_copy_assignable_v<ControlLoop>);
  // The supervisor and guidance are reachable read-only: nobody can drive the arm through them.
  static_assert(std::is_const_v<std::remove_reference_t<decltype(std::declval<ControlLoop&>().supervisor())>>);
  static_assert(std::is_const_v<std::remove_reference_t<decltype(std::declval<ControlLoop&>().guidance())>>);
  SUCCEED();
}

}  // namespace
}  // namespace mrsns::robot
