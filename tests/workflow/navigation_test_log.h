#pragma once
// Reading the robot supervisor's transitions in navigation tests.
#include <string>
#include <vector>

#include "mrsns/workflow/navigation.h"

namespace mrsns::test {

/// The first transition into Stopped or Fault, or nullptr.
inline const workflow::NavigationRobotTransition* firstStop(
    const std::vector<workflow::NavigationRobotTransition>& log) {
  for (const auto& t : log) {
    if (t.to == "Stopped" || t.to == "Fault") return &t;
  }
  return nullptr;
}

/// Every transition on its own line, for failure messages.
inline std::string describe(const std::vector<workflow::NavigationRobotTransition>& log) {
  std::string s;
  for (const auto& t : log) {
    s += "\n  cycle " + std::to_string(t.cycle) + " t=" + std::to_string(t.time_s) + " " + t.from + " -> " + t.to +
         " (" + t.reason + ": " + t.detail + ") " + t.tracking;
  }
  return s;
}

}  // namespace mrsns::test
