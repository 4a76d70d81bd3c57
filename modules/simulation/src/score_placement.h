#pragma once
// The robot-placement step against the room's truth (score_placement.cpp).
#include <nlohmann/json.hpp>

namespace mrsns::simulation {

/// Adds scored["robot_placement"] (per path: entry, target, depth and angle errors of where the true drill tip
/// went; after a stop, the tip's travel and time to rest) or a line to not_scored saying why not.
void scoreRobotPlacement(const nlohmann::json& session, const nlohmann::json& truth, nlohmann::json& scored,
                         nlohmann::json& not_scored);

}  // namespace mrsns::simulation
