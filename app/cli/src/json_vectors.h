#pragma once
// Vectors in the verbs' JSON output: [x, y, z].
#include <Eigen/Core>

#include "cli_context.h"

namespace mrsns::cli {

inline Json vectorJson(const Eigen::Vector3d& v) {
  return Json::array({v.x(), v.y(), v.z()});
}

}  // namespace mrsns::cli
