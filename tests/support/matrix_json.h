#pragma once
// A 4x4 transform as the session and the truth file write it: 16 numbers, row-major.
#include <Eigen/Core>
#include <nlohmann/json.hpp>

namespace mrsns::test {

inline nlohmann::json rowMajorJson(const Eigen::Matrix4d& m) {
  nlohmann::json j = nlohmann::json::array();
  for (int r = 0; r < 4; ++r) {
    for (int c = 0; c < 4; ++c) j.push_back(m(r, c));
  }
  return j;
}

}  // namespace mrsns::test
