#pragma once
// What the scorer's parts share: reading the session and the truth (JSON), their matrices and poses, and
// which of the session's results came from a simulated room (only those the truth can judge).
#include <Eigen/Geometry>
#include <algorithm>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "mrsns/core/error.h"

namespace mrsns::simulation::score_detail {

using Json = nlohmann::json;

inline Json readJson(const std::filesystem::path& path, const std::string& what) {
  std::ifstream in(path);
  if (!in) throw FileError("cannot read the " + what + " " + path.string());
  try {
    return Json::parse(in);
  } catch (const Json::parse_error& e) {
    throw FormatError(path.string() + " is not valid JSON (" + e.what() + ")");
  }
}

// A 4x4 from either 16 numbers (row-major) or 4 rows of 4.
inline Eigen::Matrix4d matrix(const Json& j, const std::string& what) {
  Eigen::Matrix4d m;
  if (j.is_array() && j.size() == 16) {
    for (int i = 0; i < 16; ++i) m(i / 4, i % 4) = j[static_cast<std::size_t>(i)].get<double>();
    return m;
  }
  if (j.is_array() && j.size() == 4) {
    for (int r = 0; r < 4; ++r) {
      for (int c = 0; c < 4; ++c) m(r, c) = j[static_cast<std::size_t>(r)][static_cast<std::size_t>(c)].get<double>();
    }
    return m;
  }
  throw FormatError(what + " is not a 4x4 matrix");
}

inline Json stats(const std::vector<double>& v) {
  double sum = 0.0, worst = 0.0;
  for (double x : v) {
    sum += x;
    worst = std::max(worst, x);
  }
  return {{"mean_mm", v.empty() ? 0.0 : sum / static_cast<double>(v.size())}, {"max_mm", worst}, {"points", v.size()}};
}

// Only a result measured in a simulated room can be judged by its truth: a step run on other data (a
// recording of a real device, an in-process simulation with its own patient) says so in its figures.
inline bool fromSimulatedRoom(const Json& step) {
  return step.contains("figures") && step["figures"].is_object() && step["figures"].value("simulated", false) &&
         !step["figures"].contains("simulation_truth");
}

inline const Json* recordedTransform(const Json& session, const std::string& step, const std::string& name) {
  if (!session.contains("steps") || !session["steps"].contains(step)) return nullptr;
  const Json& s = session["steps"][step];
  if (s.value("status", "") != "ok" || !fromSimulatedRoom(s) || !s.contains("figures") ||
      !s["figures"].contains("transforms") || !s["figures"]["transforms"].contains(name)) {
    return nullptr;
  }
  return &s["figures"]["transforms"][name];
}

inline Eigen::Isometry3d compactPose(const Json& p) {
  Eigen::Isometry3d t = Eigen::Isometry3d::Identity();
  t.translation() = Eigen::Vector3d(p[0].get<double>(), p[1].get<double>(), p[2].get<double>());
  t.linear() = Eigen::Quaterniond(p[3].get<double>(), p[4].get<double>(), p[5].get<double>(), p[6].get<double>())
                   .normalized()
                   .toRotationMatrix();
  return t;
}

}  // namespace mrsns::simulation::score_detail
