// ssm build|info|sample|convert and deform-trial through the real binary.
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>
#include <random>

#include "cli_runner.h"
#include "mrsns/io/mesh_io.h"
#include "mrsns/io/statismo_io.h"
#include "test_data.h"

namespace mrsns::test {
namespace {

TEST(CliSsm, InfoOfTheScalismoModel) {
  MRSNS_REQUIRE_DATA(model, "ssm/scalismo/model.h5");
  const auto r = runCli({"ssm", "info", model.string(), "--json"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const auto j = nlohmann::json::parse(r.out);
  EXPECT_EQ(j["points"], 1400);
  EXPECT_EQ(j["modes"], 50);
  EXPECT_EQ(j["format_version"], "0.9");
  EXPECT_EQ(j["representer"], "itkStandardMeshRepresenter");
}

TEST(CliSsm, BuildSampleConvertRoundTrip) {
  const auto dir = scratchDirectory("cli_ssm");
  // Six meshes in correspondence: a tetrahedron-like shape with random stretches.
  std::mt19937_64 rng(3);
  std::normal_distribution<double> n(0.0, 0.5);
  std::vector<std::string> files;
  for (int i = 0; i < 6; ++i) {
    TriangleMesh m;
    m.vertices.resize(6, 3);
    m.vertices << 10, 0, 0, -10, 0, 0, 0, 10, 0, 0, -10, 0, 0, 0, 10, 0, 0, -10;
    for (Eigen::Index v = 0; v < 6; ++v) m.vertices.row(v) *= 1.0 + 0.1 * n(rng);
    m.faces.resize(8, 3);
    m.faces << 0, 2, 4, 2, 1, 4, 1, 3, 4, 3, 0, 4, 2, 0, 5, 1, 2, 5, 3, 1, 5, 0, 3, 5;
    const auto f = dir / ("shape" + std::to_string(i) + ".vtk");
    io::writeMesh(m, f);
    files.push_back(f.string());
  }
  std::vector<std::string> args{"ssm", "build"};
  args.insert(args.end(), files.begin(), files.end());
  const auto model = (dir / "model.h5").string();
  args.insert(args.end(), {"-o", model, "--quality", "--json"});
  const auto b = runCli(args);
  ASSERT_EQ(b.exit_code, 0) << b.err;
  const auto jb = nlohmann::json::parse(b.out);
  EXPECT_EQ(jb["examples"], 6);
  EXPECT_EQ(jb["points"], 6);
  EXPECT_LE(jb["modes"].get<int>(), 5);
  EXPECT_TRUE(jb.contains("leave_one_out_mm"));
  const auto s = runCli({"ssm", "sample", model, "-o", (dir / "sample.vtk").string(), "--count", "3", "--json"});
  ASSERT_EQ(s.exit_code, 0) << s.err;
  EXPECT_EQ(nlohmann::json::parse(s.out)["samples"].size(), 3u);
  EXPECT_EQ(io::readMesh(dir / "sample_2.vtk").vertexCount(), 6);
  const auto c = runCli({"ssm", "convert", model, (dir / "double.h5").string(), "--double", "--json"});
  ASSERT_EQ(c.exit_code, 0) << c.err;
  const ShapeModel a = io::readStatismoModel(model);
  const ShapeModel d = io::readStatismoModel(dir / "double.h5");
  EXPECT_EQ(a.basis, d.basis);  // float32 values are exact in float64
  EXPECT_EQ(runCli({"ssm", "convert", model, (dir / "mean.stl").string()}).exit_code, 0);
  // A non-model file: exit 1 with a message naming the file.
  const auto bad = runCli({"ssm", "info", files[0]});
  EXPECT_EQ(bad.exit_code, 1);
  EXPECT_NE(bad.err.find("shape0.vtk"), std::string::npos);
  EXPECT_EQ(runCli({"ssm"}).exit_code, 2);
}

TEST(CliDeformTrial, PrintsTableIFigures) {
  const auto r = runCli({"deform-trial", "--cases", "2", "--frames", "40", "--seed", "3", "--json"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const auto j = nlohmann::json::parse(r.out);
  for (const char* key : {"mean", "max"}) {
    EXPECT_GT(j["surface_distance_mm"][key].get<double>(), 0.0) << key;
    EXPECT_GT(j["prior"]["surface_distance_mm"][key].get<double>(), 0.0) << key;
  }
  EXPECT_GT(j["fiducial_error_mm"]["mean"].get<double>(), 0.0);
  EXPECT_GT(j["prior"]["fiducial_error_mm"]["mean"].get<double>(), 0.0);
  EXPECT_GE(j["posterior_update_ms"]["p99"].get<double>(), j["posterior_update_ms"]["p50"].get<double>());
  EXPECT_EQ(j["noise_model"]["us_calibration_error_rms_mm"], 1.2);
  EXPECT_EQ(j["noise_model"]["tracking_noise_rms_mm"], 0.35);
  EXPECT_EQ(j["per_case"].size(), 2u);
  EXPECT_EQ(j["overlap"], "split");
  EXPECT_EQ(j["reject_implausible_frames"], true);
  int split = 0;
  for (const auto& c : j["per_case"]) split += c["contours_split"].get<int>();
  EXPECT_GT(split, 0);  // the sweep crosses the bifurcation
  EXPECT_EQ(runCli({"deform-trial", "--cases", "0"}).exit_code, 1);
  const auto bad = runCli({"deform-trial", "--cases", "1", "--overlap", "merge"});
  EXPECT_EQ(bad.exit_code, 1);
  EXPECT_NE(bad.err.find("--overlap"), std::string::npos);
}

}  // namespace
}  // namespace mrsns::test
