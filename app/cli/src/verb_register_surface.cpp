// `mrsns-cli register-surface`: ICP of points (a landmark file or a mesh's
// vertices) onto a surface mesh, with its quality figures.
#include <algorithm>
#include <cctype>
#include <cmath>
#include <sstream>

#include "cli_context.h"
#include "mrsns/core/error.h"
#include "mrsns/io/file_names.h"
#include "mrsns/io/landmarks_io.h"
#include "mrsns/io/mesh_io.h"
#include "mrsns/io/transform_io.h"
#include "mrsns/registration/surface_registration.h"

namespace mrsns::cli {
namespace {

struct RegisterSurfaceOptions {
  std::string points;
  std::string mesh;
  std::string init = "identity";
  std::string landmarks_fixed;
  std::string landmarks_moving;
  std::string method = "point-to-plane";
  std::string loss = "none";
  double trim = 1.0;
  double max_distance_mm = 0.0;
  int max_iterations = 100;
  std::string output;
};

bool isMeshFile(const std::string& path) {
  const std::string name = io::toLower(path);
  for (const char* ext : {".stl", ".vtp", ".vtk", ".obj", ".ply"}) {
    if (io::endsWith(name, ext)) return true;
  }
  return false;
}

std::vector<Eigen::Vector3d> readPoints(const std::string& path) {
  std::vector<Eigen::Vector3d> points;
  if (isMeshFile(path)) {
    const auto mesh = io::readMesh(path);
    for (Eigen::Index i = 0; i < mesh.vertexCount(); ++i) points.emplace_back(mesh.vertices.row(i).transpose());
  } else {
    for (const auto& p : io::readLandmarks(path).points) points.push_back(p.position);
  }
  return points;
}

Json matrixJson(const Eigen::Matrix4d& m) {
  Json a = Json::array();
  for (int r = 0; r < 4; ++r) {
    for (int c = 0; c < 4; ++c) a.push_back(m(r, c));
  }
  return a;
}

Report run(const RegisterSurfaceOptions& options) {
  const auto moving = readPoints(options.points);
  const auto mesh = io::readMesh(options.mesh);
  const registration::IcpSurface surface(mesh);

  registration::IcpOptions icp;
  icp.method = options.method == "point-to-point" ? registration::IcpMethod::PointToPoint
                                                  : registration::IcpMethod::PointToPlane;
  icp.loss = options.loss == "huber"   ? registration::RobustLoss::Huber
             : options.loss == "tukey" ? registration::RobustLoss::Tukey
                                       : registration::RobustLoss::None;
  icp.trim_fraction = options.trim;
  icp.max_iterations = options.max_iterations;
  if (options.max_distance_mm > 0.0) icp.max_correspondence_distance_mm = options.max_distance_mm;

  Report report;
  report.json["verb"] = "register-surface";
  report.json["points_file"] = options.points;
  report.json["mesh"] = options.mesh;
  report.json["points"] = moving.size();
  report.json["triangles"] = mesh.faceCount();
  report.json["init"] = options.init;
  report.json["method"] = options.method;

  Eigen::Isometry3d start = Eigen::Isometry3d::Identity();
  if (options.init == "landmarks") {
    if (options.landmarks_fixed.empty() || options.landmarks_moving.empty()) {
      throw InvalidArgumentError(
          "--init landmarks needs --landmarks-fixed and --landmarks-moving (the same landmarks on the mesh and in "
          "the points' frame, in the same order)");
    }
    std::vector<Eigen::Vector3d> f;
    std::vector<Eigen::Vector3d> m;
    for (const auto& p : io::readLandmarks(options.landmarks_fixed).points) f.push_back(p.position);
    for (const auto& p : io::readLandmarks(options.landmarks_moving).points) m.push_back(p.position);
    if (f.size() != m.size()) {
      throw InvalidArgumentError("the landmark files hold different numbers of points (" + std::to_string(f.size()) +
                                 " fixed, " + std::to_string(m.size()) + " moving): list the same landmarks in both");
    }
    start = registration::initialAlignmentFromLandmarks(m, f);
  } else if (options.init == "pca") {
    const auto pca = registration::initialAlignmentFromPrincipalAxes(moving, surface);
    start = pca.fixed_T_moving;
    report.json["pca_candidate_rms_mm"] = pca.candidate_rms_mm;
  }
  report.json["initial_fixed_T_moving"] = matrixJson(start.matrix());

  const auto r = registration::registerSurface(moving, surface, start, icp);
  report.json["fixed_T_moving"] = matrixJson(r.fixed_T_moving.matrix());
  report.json["rms_mm"] = r.rms_mm;
  report.json["initial_rms_mm"] = r.initial_rms_mm;
  report.json["inlier_fraction"] = r.inlier_fraction;
  report.json["inliers"] = r.inliers.size();
  report.json["iterations"] = r.iterations;
  report.json["converged"] = r.converged;
  std::vector<double> d = r.distances_mm;
  std::sort(d.begin(), d.end());
  report.json["distance_median_mm"] = d[d.size() / 2];
  report.json["distance_max_mm"] = d.back();

  std::ostringstream text;
  text << "Surface registration (" << options.method << ", " << moving.size() << " points onto " << mesh.faceCount()
       << " triangles, start: " << options.init << ")\n"
       << "  RMS: " << r.rms_mm << " mm over " << r.inliers.size() << " inliers (" << 100.0 * r.inlier_fraction
       << "%), start RMS " << r.initial_rms_mm << " mm\n"
       << "  " << r.iterations << " iterations, "
       << (r.converged ? "converged" : "NOT converged (raise --max-iterations)") << "\n  max point distance "
       << d.back() << " mm\n";
  if (!options.output.empty()) {
    // The node MovingToFixed: fixed_T_moving, by io/transform_io.h's convention whatever the extension.
    io::writeChildToParent(r.fixed_T_moving.matrix(), options.output);
    report.json["output"] = options.output;
    text << "  written: " << options.output << '\n';
  }
  report.text = text.str();
  return report;
}

}  // namespace

void registerRegisterSurfaceVerb(CLI::App& app, GlobalOptions& options, VerbList& verbs) {
  auto opts = std::make_shared<RegisterSurfaceOptions>();
  auto* sub = app.add_subcommand("register-surface",
                                 "ICP of points (landmark file or mesh vertices) onto a surface mesh: point-to-plane "
                                 "or point-to-point, trimmed or robust; RMS, inlier fraction, convergence");
  sub->add_option("--points", opts->points, "moving points: .mrk.json/.fcsv/.csv, or a mesh whose vertices are used")
      ->required();
  sub->add_option("--mesh", opts->mesh, "fixed surface mesh (.stl, .vtp, .vtk, .obj, .ply)")->required();
  sub->add_option("--init", opts->init, "initial alignment")
      ->check(CLI::IsMember({"identity", "landmarks", "pca"}))
      ->capture_default_str();
  sub->add_option("--landmarks-fixed", opts->landmarks_fixed, "landmarks on the mesh (for --init landmarks)");
  sub->add_option("--landmarks-moving", opts->landmarks_moving, "the same landmarks in the points' frame");
  sub->add_option("--method", opts->method, "ICP error metric")
      ->check(CLI::IsMember({"point-to-plane", "point-to-point"}))
      ->capture_default_str();
  sub->add_option("--loss", opts->loss, "robust weights (scale from the MAD)")
      ->check(CLI::IsMember({"none", "huber", "tukey"}))
      ->capture_default_str();
  sub->add_option("--trim", opts->trim, "fraction of the closest correspondences kept (0, 1]")
      ->check(CLI::Range(1e-6, 1.0))
      ->capture_default_str();
  sub->add_option("--max-distance", opts->max_distance_mm, "ignore correspondences farther than this (mm); 0: none")
      ->check(CLI::NonNegativeNumber);
  sub->add_option("--max-iterations", opts->max_iterations, "iteration limit")
      ->check(CLI::Range(1, 100000))
      ->capture_default_str();
  sub->add_option(
      "--output", opts->output,
      "write the transform MovingToFixed (fixed_T_moving): .tfm/.h5/.mat as 3D Slicer reads them (the inverse, "
      "LPS), .txt the plain 4x4 fixed_T_moving");
  addJsonFlag(*sub, options);
  verbs.emplace_back(sub, [opts] { return run(*opts); });
}

}  // namespace mrsns::cli
