// `mrsns-cli hmd-calibrate-cube`: HologramToTracker from recorded cube matches (paper 001
// Eq. 2-3, 12-20), reading the points file described in modules/hmd/doc/README.md:
//
//   view,fiducial,x_tracker,y_tracker,z_tracker,x_hologram,y_hologram,z_hologram
//
// or, with the cube vertices in the cube-marker frame and the CubeToTracker pose of each
// sample (first three rows, row major):
//
//   view,fiducial,x_marker,y_marker,z_marker,m00,m01,m02,m03,m10,m11,m12,m13,m20,m21,m22,m23,
//   x_hologram,y_hologram,z_hologram
//
// Several rows with the same view and fiducial are raw samples of one hold: with at least
// k_close + 1 of them the fiducial is tremor-compensated (Eq. 12-16), otherwise averaged.
#include <charconv>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>

#include "cli_context.h"
#include "mrsns/core/error.h"
#include "mrsns/core/rigid.h"
#include "mrsns/hmd/cube_calibration.h"
#include "mrsns/hmd/multi_view.h"
#include "mrsns/hmd/tremor_compensation.h"

namespace mrsns::cli {
namespace {

struct CubeVerbOptions {
  std::string points;
  double omega = 1.5;
};

struct Fiducial {
  std::string name;
  Eigen::Vector3d hologram = Eigen::Vector3d::Zero();
  std::vector<Eigen::Vector3d> samples_tracker;
};

struct View {
  std::string name;
  std::vector<Fiducial> fiducials;
};

std::vector<std::string> splitCsv(const std::string& line) {
  std::vector<std::string> out;
  std::stringstream ss(line);
  std::string cell;
  while (std::getline(ss, cell, ',')) {
    const auto a = cell.find_first_not_of(" \t\r");
    const auto b = cell.find_last_not_of(" \t\r");
    out.push_back(a == std::string::npos ? "" : cell.substr(a, b - a + 1));
  }
  return out;
}

double number(const std::string& cell, const std::string& file, int line, const std::string& column) {
  double v = 0.0;
  const auto res = std::from_chars(cell.data(), cell.data() + cell.size(), v);
  if (res.ec != std::errc() || res.ptr != cell.data() + cell.size() || !std::isfinite(v)) {
    throw FormatError("cube points file '" + file + "' line " + std::to_string(line) + ": column '" + column +
                      "' is '" + cell + "', not a finite number");
  }
  return v;
}

std::vector<View> readPoints(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw FileError("cannot open cube points file '" + path + "'; check the path and permissions");
  std::string line;
  int line_no = 0;
  std::vector<std::string> header;
  while (header.empty() && std::getline(in, line)) {
    ++line_no;
    if (line.find_first_not_of(" \t\r") == std::string::npos || line[line.find_first_not_of(" \t")] == '#') continue;
    header = splitCsv(line);
  }
  if (header.empty()) throw FormatError("cube points file '" + path + "' is empty; expected a header line");
  std::map<std::string, std::size_t> col;
  for (std::size_t i = 0; i < header.size(); ++i) col[header[i]] = i;
  auto need = [&](const std::string& name) {
    const auto it = col.find(name);
    if (it == col.end()) {
      throw FormatError("cube points file '" + path + "' has no column '" + name +
                        "'; the header needs view, fiducial, x/y/z_hologram and either x/y/z_tracker or "
                        "x/y/z_marker with m00..m23 (CubeToTracker)");
    }
    return it->second;
  };
  const bool marker = col.count("x_marker") > 0 && col.count("x_tracker") == 0;
  const std::size_t c_view = need("view"), c_fid = need("fiducial");
  const std::size_t c_h[3] = {need("x_hologram"), need("y_hologram"), need("z_hologram")};
  std::size_t c_p[3];
  std::size_t c_m[12] = {};
  if (marker) {
    c_p[0] = need("x_marker"), c_p[1] = need("y_marker"), c_p[2] = need("z_marker");
    for (int r = 0; r < 3; ++r) {
      for (int c = 0; c < 4; ++c) c_m[4 * r + c] = need("m" + std::to_string(r) + std::to_string(c));
    }
  } else {
    c_p[0] = need("x_tracker"), c_p[1] = need("y_tracker"), c_p[2] = need("z_tracker");
  }
  std::vector<View> views;
  while (std::getline(in, line)) {
    ++line_no;
    const auto first = line.find_first_not_of(" \t\r");
    if (first == std::string::npos || line[first] == '#') continue;
    const auto cells = splitCsv(line);
    if (cells.size() != header.size()) {
      throw FormatError("cube points file '" + path + "' line " + std::to_string(line_no) + " has " +
                        std::to_string(cells.size()) + " columns, the header " + std::to_string(header.size()));
    }
    auto num = [&](std::size_t c) { return number(cells[c], path, line_no, header[c]); };
    Eigen::Vector3d p(num(c_p[0]), num(c_p[1]), num(c_p[2]));
    if (marker) {
      Eigen::Matrix4d M = Eigen::Matrix4d::Identity();
      for (int r = 0; r < 3; ++r) {
        for (int c = 0; c < 4; ++c) M(r, c) = num(c_m[4 * r + c]);
      }
      if (!isRigid(M, 1e-3)) {
        throw FormatError("cube points file '" + path + "' line " + std::to_string(line_no) +
                          ": the CubeToTracker matrix m00..m23 is not rigid");
      }
      p = orthonormalize(M) * p;
    }
    const Eigen::Vector3d h(num(c_h[0]), num(c_h[1]), num(c_h[2]));
    auto vit = std::find_if(views.begin(), views.end(), [&](const View& v) { return v.name == cells[c_view]; });
    if (vit == views.end()) {
      views.push_back({cells[c_view], {}});
      vit = views.end() - 1;
    }
    auto fit = std::find_if(vit->fiducials.begin(), vit->fiducials.end(),
                            [&](const Fiducial& f) { return f.name == cells[c_fid]; });
    if (fit == vit->fiducials.end()) {
      vit->fiducials.push_back({cells[c_fid], h, {}});
      fit = vit->fiducials.end() - 1;
    } else if ((fit->hologram - h).norm() > 1e-6) {
      throw FormatError("cube points file '" + path + "' line " + std::to_string(line_no) + ": fiducial '" + fit->name +
                        "' of view '" + vit->name + "' has a different hologram position than its first sample");
    }
    fit->samples_tracker.push_back(p);
  }
  if (views.empty()) throw FormatError("cube points file '" + path + "' has a header but no points");
  return views;
}

Json rowMajor(const Eigen::Isometry3d& T) {
  Json a = Json::array();
  for (double v : toRowMajor(T)) a.push_back(v);
  return a;
}

Report run(const CubeVerbOptions& o) {
  const auto views = readPoints(o.points);
  hmd::TremorOptions tremor;
  tremor.omega = o.omega;
  Report rep;
  rep.json["verb"] = "hmd-calibrate-cube";
  rep.json["points"] = o.points;
  Json jviews = Json::array();
  std::vector<Eigen::Isometry3d> per_view;
  std::ostringstream text;
  text.precision(4);
  for (const auto& v : views) {
    std::vector<Eigen::Vector3d> tra, hol;
    int compensated = 0, total_samples = 0, dropped = 0;
    for (const auto& f : v.fiducials) {
      total_samples += static_cast<int>(f.samples_tracker.size());
      if (f.samples_tracker.size() > static_cast<std::size_t>(tremor.k_close)) {
        const auto c = hmd::compensateTremor(f.samples_tracker, tremor);
        tra.push_back(c.centre);
        dropped += static_cast<int>(f.samples_tracker.size()) - c.kept_count;
        ++compensated;
      } else {
        Eigen::Vector3d mean = Eigen::Vector3d::Zero();
        for (const auto& p : f.samples_tracker) mean += p / static_cast<double>(f.samples_tracker.size());
        tra.push_back(mean);
      }
      hol.push_back(f.hologram);
    }
    hmd::CubeCalibrationResult c;
    try {
      c = hmd::calibrateCube(tra, hol);
    } catch (const InvalidArgumentError& e) {
      throw InvalidArgumentError("view '" + v.name + "' of '" + o.points + "': " + e.what());
    }
    per_view.push_back(c.tracker_T_hololens);
    Json residuals = Json::object();
    for (std::size_t i = 0; i < v.fiducials.size(); ++i) residuals[v.fiducials[i].name] = c.rigid_residuals_mm[i];
    jviews.push_back(
        {{"view", v.name},
         {"fiducials", v.fiducials.size()},
         {"samples", total_samples},
         {"tremor_compensated_fiducials", compensated},
         {"dropped_samples", dropped},
         {"rigid",
          {{"HologramToTracker", rowMajor(c.tracker_T_hololens)},
           {"rms_mm", c.rigid_rms_mm},
           {"residuals_mm", residuals}}},
         {"affine",
          {{"rms_mm", c.affine_rms_mm},
           {"singular_values", {c.affine_singular_values(0), c.affine_singular_values(1), c.affine_singular_values(2)}},
           {"rigidity_deviation", c.affine_rigidity_deviation},
           {"dlt_condition_number", c.dlt_condition_number}}}});
    text << "view " << v.name << ": " << v.fiducials.size() << " fiducials, rigid RMS " << c.rigid_rms_mm
         << " mm, affine RMS " << c.affine_rms_mm << " mm, DLT condition " << c.dlt_condition_number << "\n";
  }
  rep.json["views"] = jviews;
  const auto mv = hmd::averageViews(per_view);
  rep.json["HologramToTracker"] = rowMajor(mv.tracker_T_hololens);
  rep.json["view_spread"] = {{"views", per_view.size()},
                             {"max_pairwise_rotation_deg", mv.max_pairwise_rotation_rad * 180.0 / M_PI},
                             {"max_pairwise_translation_mm", mv.max_pairwise_translation_mm},
                             {"rotation_rms_deg", mv.rotation_rms_rad * 180.0 / M_PI},
                             {"translation_rms_mm", mv.translation_rms_mm}};
  text << "HologramToTracker averaged over " << per_view.size() << " view(s); spread "
       << mv.max_pairwise_rotation_rad * 180.0 / M_PI << " deg, " << mv.max_pairwise_translation_mm << " mm\n";
  rep.text = text.str();
  return rep;
}

}  // namespace

void registerHmdCalibrateCubeVerb(CLI::App& app, GlobalOptions& options, VerbList& verbs) {
  auto opts = std::make_shared<CubeVerbOptions>();
  auto* sub = app.add_subcommand("hmd-calibrate-cube",
                                 "HologramToTracker from calibration-cube matches per view (paper 001 Eq. 2-3), "
                                 "with tremor compensation and multi-view averaging");
  sub->add_option("--points", opts->points, "CSV of matched points (see modules/hmd/doc/README.md)")->required();
  sub->add_option("--omega", opts->omega, "tremor filter weight (Eq. 14)")->capture_default_str();
  addJsonFlag(*sub, options);
  verbs.emplace_back(sub, [opts] { return run(*opts); });
}

}  // namespace mrsns::cli
