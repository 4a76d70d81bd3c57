#include "hmd_cube_calibration.h"

#include <cmath>
#include <cstdio>
#include <fstream>

#include "mrsns/core/error.h"
#include "mrsns/core/rigid.h"
#include "mrsns/hmd/cube_calibration.h"
#include "mrsns/hmd/multi_view.h"
#include "mrsns/hmd/tremor_compensation.h"

namespace mrsns::workflow::detail {

namespace {

using Json = nlohmann::json;

Json rowMajor(const Eigen::Isometry3d& t) {
  Json a = Json::array();
  for (int r = 0; r < 4; ++r) {
    for (int c = 0; c < 4; ++c) a.push_back(t.matrix()(r, c));
  }
  return a;
}

Eigen::Isometry3d isometryFrom(const Json& j, const std::string& what) {
  if (!j.is_array() || j.size() != 16) throw FormatError(what + " must be 16 numbers (row-major 4x4)");
  Eigen::Matrix4d m;
  for (int i = 0; i < 16; ++i) {
    if (!j[static_cast<std::size_t>(i)].is_number()) throw FormatError(what + " must be 16 numbers (row-major 4x4)");
    m(i / 4, i % 4) = j[static_cast<std::size_t>(i)].get<double>();
  }
  if (!isRigid(m, 1e-4)) throw FormatError(what + " is not a rigid transform");
  return orthonormalize(m);
}

}  // namespace

std::vector<Eigen::Vector3d> CubeDefinition::verticesMarker() const {
  std::vector<Eigen::Vector3d> out;
  const double h = 0.5 * edge_mm;
  for (int v = 0; v < 8; ++v) {
    out.push_back(marker_T_cube * Eigen::Vector3d((v & 1) ? h : -h, (v & 2) ? h : -h, (v & 4) ? h : -h));
  }
  return out;
}

TriangleMesh CubeDefinition::mesh() const {
  TriangleMesh m;
  const auto v = verticesMarker();
  m.vertices.resize(8, 3);
  for (int i = 0; i < 8; ++i) m.vertices.row(i) = v[static_cast<std::size_t>(i)].transpose();
  // Two triangles per face, wound counter-clockwise seen from outside.
  m.faces.resize(12, 3);
  m.faces << 0, 2, 3, 0, 3, 1,  // z-
      4, 5, 7, 4, 7, 6,         // z+
      0, 1, 5, 0, 5, 4,         // y-
      2, 6, 7, 2, 7, 3,         // y+
      0, 4, 6, 0, 6, 2,         // x-
      1, 3, 7, 1, 7, 5;         // x+
  m.name = name;
  return m;
}

CubeDefinition readCubeDefinition(const std::filesystem::path& file) {
  std::ifstream in(file);
  if (!in) throw FileError("cannot read the calibration cube's definition '" + file.string() + "'");
  Json j;
  try {
    j = Json::parse(in);
  } catch (const Json::parse_error& e) {
    throw FormatError("the calibration cube's definition '" + file.string() + "' is not valid JSON (" + e.what() +
                      ")");
  }
  const std::string what = "the calibration cube's definition '" + file.string() + "'";
  if (!j.is_object() || j.value("format", "") != "mrsns-calibration-cube/1") {
    throw FormatError(what + " is not an mrsns-calibration-cube/1 file");
  }
  CubeDefinition c;
  c.file = file.string();
  c.name = j.value("name", "calibration cube");
  if (!j.contains("edge_mm") || !j["edge_mm"].is_number()) throw FormatError(what + " needs edge_mm (a number)");
  c.edge_mm = j["edge_mm"].get<double>();
  if (!(c.edge_mm >= 10.0 && c.edge_mm <= 500.0)) throw FormatError(what + ": edge_mm must be 10 to 500 mm");
  if (j.contains("cube_to_marker")) c.marker_T_cube = isometryFrom(j["cube_to_marker"], what + ": cube_to_marker");
  return c;
}

HoldSamples holdSamples(const std::vector<TrackedFrame>& frames, const CubeHold& hold, const std::string& transform) {
  HoldSamples s;
  for (const auto& f : frames) {
    if (f.timestamp < hold.start || f.timestamp > hold.end) continue;
    ++s.frames;
    const auto it = f.transforms.find(transform);
    if (it == f.transforms.end() || it->second.status != TransformStatus::Ok || !isRigid(it->second.matrix, 1e-3)) {
      ++s.untracked;
      continue;
    }
    s.tracker_T_marker.push_back(orthonormalize(it->second.matrix));
  }
  return s;
}

CubeViewSolution solveCubeHold(const HoldSamples& samples, const CubeHold& hold, const CubeDefinition& cube,
                               const CubeHoldsOptions& options) {
  if (samples.tracker_T_marker.size() <= static_cast<std::size_t>(options.k_close)) {
    throw InvalidArgumentError("view '" + hold.view + "': " + std::to_string(samples.tracker_T_marker.size()) +
                               " tracked samples of the cube in its hold, at least " +
                               std::to_string(options.k_close + 1) + " needed");
  }
  const auto vertices = cube.verticesMarker();
  std::vector<std::vector<Eigen::Vector3d>> per_fiducial(vertices.size());
  std::vector<Eigen::Vector3d> hologram;
  for (std::size_t i = 0; i < vertices.size(); ++i) {
    for (const auto& t : samples.tracker_T_marker) per_fiducial[i].push_back(t * vertices[i]);
    hologram.push_back(hold.hologram_T_marker * vertices[i]);
  }
  hmd::TremorOptions tremor;
  tremor.k_close = options.k_close;
  tremor.omega = options.omega;
  hmd::ViewCalibrationResult view;
  if (options.tremor_compensation) {
    view = hmd::calibrateViewWithTremorCompensation(per_fiducial, hologram, tremor);
  } else {
    for (const auto& f : per_fiducial) {
      view.fiducial_tracker.push_back(f.front());
      view.dropped_samples.push_back(0);
    }
    view.calibration = hmd::calibrateCube(view.fiducial_tracker, hologram);
  }
  CubeViewSolution s;
  s.tracker_T_hologram = view.calibration.tracker_T_hololens;
  s.rigid_rms_mm = view.calibration.rigid_rms_mm;
  s.affine_rms_mm = view.calibration.affine_rms_mm;
  s.samples = static_cast<int>(samples.tracker_T_marker.size());
  s.untracked = samples.untracked;
  for (int d : view.dropped_samples) s.dropped += d;
  for (std::size_t i = 0; i < per_fiducial.size(); ++i) {
    // How still the hand was: every sample's distance from the compensated centre, slips included.
    double sum = 0.0;
    for (const auto& p : per_fiducial[i]) sum += (p - view.fiducial_tracker[i]).squaredNorm();
    s.largest_spread_mm =
        std::max(s.largest_spread_mm, std::sqrt(sum / static_cast<double>(per_fiducial[i].size())));
  }
  return s;
}

CubeHoldsSolution solveCubeHolds(const std::vector<TrackedFrame>& frames, const std::vector<CubeHold>& holds,
                                 const CubeDefinition& cube, const CubeHoldsOptions& options) {
  if (holds.empty()) throw InvalidArgumentError("no hold of the cube on its hologram to calibrate from");
  CubeHoldsSolution out;
  std::vector<Eigen::Isometry3d> per_view;
  for (const auto& hold : holds) {
    out.views.push_back(solveCubeHold(holdSamples(frames, hold, options.transform), hold, cube, options));
    per_view.push_back(out.views.back().tracker_T_hologram);
  }
  const auto mv = hmd::averageViews(per_view);
  out.tracker_T_hologram = mv.tracker_T_hololens;
  std::vector<Eigen::Vector3d> centres;
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (std::size_t i = 0; i < holds.size(); ++i) {
    centres.push_back(per_view[i] * (holds[i].hologram_T_marker * cube.marker_T_cube.translation()));
    mean += centres.back() / static_cast<double>(holds.size());
  }
  double sum = 0.0;
  for (const auto& c : centres) sum += (c - mean).squaredNorm();
  out.at_cube_rms_mm = std::sqrt(sum / static_cast<double>(centres.size()));
  out.max_pairwise_rotation_deg = mv.max_pairwise_rotation_rad * 180.0 / M_PI;
  out.max_pairwise_translation_mm = mv.max_pairwise_translation_mm;
  return out;
}

Json holdsJson(const CubeDefinition& cube, const CubeHoldsOptions& options, const std::vector<CubeHold>& holds) {
  Json h = Json::array();
  for (const auto& hold : holds) {
    h.push_back({{"view", hold.view},
                 {"hologram_T_marker", rowMajor(hold.hologram_T_marker)},
                 {"start", hold.start},
                 {"end", hold.end},
                 {"confirmed_by", hold.confirmed_by}});
  }
  return {{"format", "mrsns-cube-holds/1"},
          {"cube", {{"name", cube.name}, {"file", cube.file}, {"edge_mm", cube.edge_mm},
                    {"cube_to_marker", rowMajor(cube.marker_T_cube)}}},
          {"transform", options.transform},
          {"tremor_compensation", options.tremor_compensation},
          {"holds", h}};
}

std::vector<CubeHold> holdsFromJson(const Json& j, const std::string& what) {
  if (!j.is_object() || j.value("format", "") != "mrsns-cube-holds/1" || !j.contains("holds") ||
      !j["holds"].is_array()) {
    throw FormatError(what + " is not an mrsns-cube-holds/1 file (written by hmd-calibration)");
  }
  std::vector<CubeHold> out;
  for (const auto& h : j["holds"]) {
    CubeHold hold;
    if (!h.is_object() || !h.contains("start") || !h["start"].is_number() || !h.contains("end") ||
        !h["end"].is_number() || !h.contains("hologram_T_marker")) {
      throw FormatError(what + ": a hold needs start, end and hologram_T_marker");
    }
    hold.view = h.value("view", "view " + std::to_string(out.size() + 1));
    hold.hologram_T_marker = isometryFrom(h["hologram_T_marker"], what + ": hologram_T_marker");
    hold.start = h["start"].get<double>();
    hold.end = h["end"].get<double>();
    hold.confirmed_by = h.value("confirmed_by", "");
    if (!(hold.end > hold.start)) throw FormatError(what + ": hold '" + hold.view + "' ends before it starts");
    out.push_back(hold);
  }
  return out;
}

void writeCubePointsCsv(const std::filesystem::path& file, const std::vector<TrackedFrame>& frames,
                        const std::vector<CubeHold>& holds, const CubeDefinition& cube,
                        const CubeHoldsOptions& options) {
  std::ofstream out(file, std::ios::trunc);
  if (!out) throw FileError("cannot write '" + file.string() + "'");
  out << "view,fiducial,x_marker,y_marker,z_marker,m00,m01,m02,m03,m10,m11,m12,m13,m20,m21,m22,m23,"
         "x_hologram,y_hologram,z_hologram\n";
  const auto vertices = cube.verticesMarker();
  char buffer[64];
  const auto put = [&](double x) {
    std::snprintf(buffer, sizeof buffer, ",%.17g", x);
    out << buffer;
  };
  for (std::size_t h = 0; h < holds.size(); ++h) {
    auto samples = holdSamples(frames, holds[h], options.transform);
    // Uncompensated: the one sample each fiducial is taken from (the verb then averages one sample: itself).
    if (!options.tremor_compensation && !samples.tracker_T_marker.empty()) samples.tracker_T_marker.resize(1);
    // Views are told apart by name: a repeated name gets its order number.
    const std::string view = holds[h].view + "_" + std::to_string(h + 1);
    for (const auto& t : samples.tracker_T_marker) {
      for (std::size_t i = 0; i < vertices.size(); ++i) {
        out << view << ",V" << i;
        for (int k = 0; k < 3; ++k) put(vertices[i][k]);
        for (int r = 0; r < 3; ++r) {
          for (int c = 0; c < 4; ++c) put(t.matrix()(r, c));
        }
        const Eigen::Vector3d hol = holds[h].hologram_T_marker * vertices[i];
        for (int k = 0; k < 3; ++k) put(hol[k]);
        out << "\n";
      }
    }
  }
  if (!out) throw FileError("writing '" + file.string() + "' failed (disk full?)");
}

}  // namespace mrsns::workflow::detail
