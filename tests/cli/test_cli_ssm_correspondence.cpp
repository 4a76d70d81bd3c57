// ssm build --correspondence nonrigid: meshes of different tessellations
// (not in correspondence) become a model with the reference's topology.
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <nlohmann/json.hpp>
#include <numbers>

#include "cli_runner.h"
#include "mrsns/io/mesh_io.h"
#include "mrsns/io/statismo_io.h"
#include "test_data.h"

namespace mrsns::test {
namespace {

// A latitude/longitude ellipsoid: `rings` x `sectors` (different for every
// example, so the vertices differ).
TriangleMesh ellipsoid(int rings, int sectors, const Eigen::Vector3d& r) {
  TriangleMesh m;
  const int n = 2 + (rings - 1) * sectors;
  m.vertices.resize(n, 3);
  m.vertices.row(0) << 0, 0, r.z();
  m.vertices.row(n - 1) << 0, 0, -r.z();
  auto at = [&](int i, int j) { return 1 + (i - 1) * sectors + (j % sectors); };
  for (int i = 1; i < rings; ++i) {
    for (int j = 0; j < sectors; ++j) {
      const double th = std::numbers::pi * i / rings, ph = 2.0 * std::numbers::pi * j / sectors;
      m.vertices.row(at(i, j)) << r.x() * std::sin(th) * std::cos(ph), r.y() * std::sin(th) * std::sin(ph),
          r.z() * std::cos(th);
    }
  }
  std::vector<Eigen::Vector3i> f;
  for (int j = 0; j < sectors; ++j) f.emplace_back(0, at(1, j), at(1, j + 1));
  for (int i = 1; i + 1 < rings; ++i) {
    for (int j = 0; j < sectors; ++j) {
      f.emplace_back(at(i, j), at(i + 1, j), at(i + 1, j + 1));
      f.emplace_back(at(i, j), at(i + 1, j + 1), at(i, j + 1));
    }
  }
  for (int j = 0; j < sectors; ++j) f.emplace_back(n - 1, at(rings - 1, j + 1), at(rings - 1, j));
  m.faces.resize(static_cast<Eigen::Index>(f.size()), 3);
  for (std::size_t k = 0; k < f.size(); ++k) m.faces.row(static_cast<Eigen::Index>(k)) = f[k].transpose();
  return m;
}

TEST(CliSsmCorrespondence, NonRigidBuildsAModelFromMeshesNotInCorrespondence) {
  const auto dir = scratchDirectory("cli_ssm_corr");
  const Eigen::Vector3d r(30, 20, 15);
  const auto ref = (dir / "reference.vtk").string();
  io::writeMesh(ellipsoid(12, 24, r), ref);
  std::vector<std::string> args{"ssm", "build"};
  std::vector<std::string> lms;
  for (int k = 0; k < 3; ++k) {
    const double s = 1.0 + 0.06 * k;
    const auto f = (dir / ("example" + std::to_string(k) + ".vtk")).string();
    io::writeMesh(ellipsoid(15 + 2 * k, 29 + 3 * k, r * s), f);
    args.push_back(f);
    // Landmarks at the axis ends start the rigid stage (the ellipsoid is symmetric).
    const auto l = (dir / ("example" + std::to_string(k) + ".csv")).string();
    std::ofstream(l) << "A," << 30 * s << ",0,0\nB," << -30 * s << ",0,0\nC,0," << 20 * s << ",0\nD,0,0," << 15 * s
                     << "\n";
    lms.push_back(l);
  }
  const auto ref_lm = (dir / "reference.csv").string();
  std::ofstream(ref_lm) << "A,30,0,0\nB,-30,0,0\nC,0,20,0\nD,0,0,15\n";
  const auto model = (dir / "model.h5").string();
  args.insert(args.end(),
              {"--correspondence", "nonrigid", "--reference", ref, "--reference-landmarks", ref_lm, "--landmarks"});
  args.insert(args.end(), lms.begin(), lms.end());
  args.insert(args.end(), {"--no-align", "-o", model, "--json"});
  const auto b = runCli(args);
  ASSERT_EQ(b.exit_code, 0) << b.err;
  const auto j = nlohmann::json::parse(b.out);
  EXPECT_EQ(j["correspondence"], "nonrigid");
  EXPECT_EQ(j["points"], 2 + 11 * 24);
  ASSERT_EQ(j["fits"].size(), 3u);
  for (const auto& f : j["fits"]) {
    // Resampling error of these coarse meshes: chord sag r (1 - cos(pi/24)) ~ 0.26 mm.
    EXPECT_LT(f["fitted_to_example_mm"]["mean"].get<double>(), 0.3);
    // Landmarks only start the rigid stage; on this featureless surface the
    // vertices may slide along it, bounded by the reference's edge (2 pi 30 / 24 ~ 7.9 mm).
    EXPECT_LT(f["landmark_error_mm"][0].get<double>(), 7.9);
  }
  // Sizes 1.00, 1.06, 1.12: one dominant mode (the rest is that sliding).
  const ShapeModel m = io::readStatismoModel(model);
  EXPECT_GT(m.variances[0] / m.variances.sum(), 0.85);

  // Without the option, meshes not in correspondence are refused (exit 1).
  const auto refused = runCli({"ssm", "build", args[2], args[3], "-o", (dir / "x.h5").string()});
  EXPECT_EQ(refused.exit_code, 1);
  // --correspondence nonrigid without --reference is a usage error reported as exit 1 with one line.
  const auto noref =
      runCli({"ssm", "build", args[2], args[3], "--correspondence", "nonrigid", "-o", (dir / "y.h5").string()});
  EXPECT_EQ(noref.exit_code, 1);
  EXPECT_NE(noref.err.find("--reference"), std::string::npos) << noref.err;
}

}  // namespace
}  // namespace mrsns::test
