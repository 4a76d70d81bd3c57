// register-surface, find-fiducials and plan-check through the real binary,
// on synthetic meshes and points written to files.
#include <gtest/gtest.h>

#include <fstream>
#include <nlohmann/json.hpp>

#include "../registration/surface_fixtures.h"
#include "cli_runner.h"
#include "test_data.h"

namespace mrsns::test {
namespace {

void writeObj(const TriangleMesh& mesh, const std::filesystem::path& path) {
  std::ofstream out(path);
  out.precision(17);
  for (Eigen::Index i = 0; i < mesh.vertexCount(); ++i) {
    out << "v " << mesh.vertices(i, 0) << ' ' << mesh.vertices(i, 1) << ' ' << mesh.vertices(i, 2) << '\n';
  }
  for (Eigen::Index f = 0; f < mesh.faceCount(); ++f) {
    out << "f " << mesh.faces(f, 0) + 1 << ' ' << mesh.faces(f, 1) + 1 << ' ' << mesh.faces(f, 2) + 1 << '\n';
  }
}

void writeCsv(const std::vector<Eigen::Vector3d>& points, const std::filesystem::path& path) {
  std::ofstream out(path);
  out.precision(17);
  for (std::size_t i = 0; i < points.size(); ++i) {
    out << "P-" << i + 1 << ',' << points[i].x() << ',' << points[i].y() << ',' << points[i].z() << '\n';
  }
}

Eigen::Isometry3d matrixFromJson(const nlohmann::json& a) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 4; ++c) T.matrix()(r, c) = a[static_cast<std::size_t>(4 * r + c)].get<double>();
  }
  return T;
}

struct SurfaceFiles {
  std::filesystem::path mesh;
  std::filesystem::path points;
  Eigen::Isometry3d truth;
  Eigen::Vector3d centroid = Eigen::Vector3d::Zero();
};

// 800 points with 0.2 mm per-axis noise from the vertebra-like surface,
// mapped by truth^-1.
SurfaceFiles writeSurfaceProblem(const std::filesystem::path& dir, const Eigen::Isometry3d& truth) {
  SurfaceFiles f;
  f.truth = truth;
  const auto mesh = vertebraLikeMesh(41, 64);
  f.mesh = dir / "vertebra.obj";
  writeObj(mesh, f.mesh);
  const auto moving = transformPoints(truth.inverse(), sampleSurface(mesh, 800, 0.2, 11));
  for (const auto& p : moving) f.centroid += p;
  f.centroid /= static_cast<double>(moving.size());
  f.points = dir / "points.csv";
  writeCsv(moving, f.points);
  return f;
}

TEST(CliRegisterSurface, RecoversTheTransformAndWritesIt) {
  const auto dir = scratchDirectory("icp");
  const auto truth = makePose(Eigen::Vector3d(0.1, 0.15, -0.1), Eigen::Vector3d(5, -6, 4));
  const auto files = writeSurfaceProblem(dir, truth);
  const auto tfm = dir / "PointsToMesh.tfm";
  const auto result = runCli({"register-surface", "--points", files.points.string(), "--mesh", files.mesh.string(),
                              "--output", tfm.string(), "--json"});
  ASSERT_EQ(result.exit_code, 0) << result.err;
  const auto json = nlohmann::json::parse(result.out);
  EXPECT_TRUE(json["converged"].get<bool>());
  // 800 points with 0.2 mm noise: pose error ~0.01 mm / 0.05 deg; RMS = sigma +- 10%.
  const auto e = poseError(matrixFromJson(json["fixed_T_moving"]), truth, files.centroid);
  EXPECT_LT(e.rotation, 0.2 * kDegree);
  EXPECT_LT(e.translation, 0.08);
  EXPECT_NEAR(json["rms_mm"].get<double>(), 0.2, 0.02);
  EXPECT_DOUBLE_EQ(json["inlier_fraction"].get<double>(), 1.0);
  EXPECT_GT(json["iterations"].get<int>(), 0);
  EXPECT_TRUE(std::filesystem::exists(tfm));
}

TEST(CliRegisterSurface, PrincipalAxesStartRecoversAHalfTurn) {
  const auto dir = scratchDirectory("icp");
  const auto truth = makePose(Eigen::Vector3d(0.0, 0.0, 170.0 * kDegree), Eigen::Vector3d(60, 0, -30));
  const auto files = writeSurfaceProblem(dir, truth);
  const auto result = runCli({"register-surface", "--points", files.points.string(), "--mesh", files.mesh.string(),
                              "--init", "pca", "--method", "point-to-point", "--max-iterations", "300", "--json"});
  ASSERT_EQ(result.exit_code, 0) << result.err;
  const auto json = nlohmann::json::parse(result.out);
  EXPECT_EQ(json["pca_candidate_rms_mm"].size(), 4u);
  const auto e = poseError(matrixFromJson(json["fixed_T_moving"]), truth, files.centroid);
  EXPECT_LT(e.rotation, 0.2 * kDegree);
  EXPECT_LT(e.translation, 0.08);
}

TEST(CliRegisterSurface, LandmarkStartAndTrimming) {
  const auto dir = scratchDirectory("icp");
  const auto truth = makePose(Eigen::Vector3d(1.0, -0.5, 0.8), Eigen::Vector3d(20, 30, -10));
  const auto files = writeSurfaceProblem(dir, truth);
  const std::vector<Eigen::Vector3d> fixed_lm = {{20, 0, 0}, {0, 14, 0}, {0, 0, 11}, {-20, 0, 0}};
  writeCsv(fixed_lm, dir / "fixed.csv");
  writeCsv(transformPoints(truth.inverse(), fixed_lm), dir / "moving.csv");
  const auto result = runCli({"register-surface", "--points", files.points.string(), "--mesh", files.mesh.string(),
                              "--init", "landmarks", "--landmarks-fixed", (dir / "fixed.csv").string(),
                              "--landmarks-moving", (dir / "moving.csv").string(), "--trim", "0.9", "--json"});
  ASSERT_EQ(result.exit_code, 0) << result.err;
  const auto json = nlohmann::json::parse(result.out);
  EXPECT_NEAR(json["inlier_fraction"].get<double>(), 0.9, 0.002);
  const auto e = poseError(matrixFromJson(json["fixed_T_moving"]), truth, files.centroid);
  EXPECT_LT(e.rotation, 0.2 * kDegree);
  EXPECT_LT(e.translation, 0.08);
}

TEST(CliRegisterSurface, BadInputExitsWithAClearError) {
  const auto dir = scratchDirectory("icp");
  const auto files = writeSurfaceProblem(dir, Eigen::Isometry3d::Identity());
  writeCsv({{0, 0, 0}, {1, 0, 0}}, dir / "two.csv");
  auto r = runCli({"register-surface", "--points", (dir / "two.csv").string(), "--mesh", files.mesh.string()});
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find("at least 3"), std::string::npos) << r.err;
  r = runCli(
      {"register-surface", "--points", files.points.string(), "--mesh", files.mesh.string(), "--init", "landmarks"});
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find("--landmarks-fixed"), std::string::npos) << r.err;
  r = runCli({"register-surface", "--points", files.points.string(), "--mesh", files.mesh.string(), "--trim", "1.5"});
  EXPECT_EQ(r.exit_code, 2);
  r = runCli({"register-surface", "--points", files.points.string(), "--mesh", (dir / "missing.stl").string()});
  EXPECT_EQ(r.exit_code, 1);
}

TEST(CliFindFiducials, FindsTheScrewEntryPointsAndWritesMarkups) {
  const auto dir = scratchDirectory("fiducials");
  const auto bone = vertebraLikeMesh(61, 80);
  writeObj(bone, dir / "bone.obj");
  // Two screws along the x axis (both ends of the shape), perpendicular-ish to the surface.
  const double x_plus = 20.0 * vertebraRadius(Eigen::Vector3d::UnitX());
  const double x_minus = 20.0 * vertebraRadius(-Eigen::Vector3d::UnitX());
  const TriangleMesh screws[2] = {screwMesh({Eigen::Vector3d(x_plus, 0, 0), Eigen::Vector3d::UnitX()}),
                                  screwMesh({Eigen::Vector3d(-x_minus, 0, 0), -Eigen::Vector3d::UnitX()})};
  writeObj(mergeMeshes(screws), dir / "screws.obj");
  const auto out = dir / "F.mrk.json";
  const auto r = runCli({"find-fiducials", "--screws", (dir / "screws.obj").string(), "--bone",
                         (dir / "bone.obj").string(), "--count", "2", "--output", out.string(), "--json"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const auto json = nlohmann::json::parse(r.out);
  ASSERT_EQ(json["fiducials"].size(), 2u);
  // Ordered by x. The mesh's vertex at (+-x, 0, 0) lies exactly on the analytic surface (a ring vertex).
  EXPECT_NEAR(json["fiducials"][0]["position_mm"][0].get<double>(), -x_minus, 0.5);
  EXPECT_NEAR(json["fiducials"][1]["position_mm"][0].get<double>(), x_plus, 0.5);
  EXPECT_TRUE(json["fiducials"][1]["axis_hits_bone"].get<bool>());
  std::ifstream in(out);
  const auto markups = nlohmann::json::parse(in);
  EXPECT_EQ(markups["markups"][0]["controlPoints"].size(), 2u);
  EXPECT_EQ(markups["markups"][0]["controlPoints"][0]["label"].get<std::string>(), "F-1");
}

TEST(CliFindFiducials, MoreFiducialsThanVerticesIsRefused) {
  const auto dir = scratchDirectory("fiducials");
  writeObj(vertebraLikeMesh(21, 30), dir / "bone.obj");
  writeObj(cylinderMesh(1.0, 0.0, 5.0, 2, 4), dir / "screw.obj");  // 10 vertices
  const auto r = runCli({"find-fiducials", "--screws", (dir / "screw.obj").string(), "--bone",
                         (dir / "bone.obj").string(), "--count", "11", "--json"});
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find("11"), std::string::npos) << r.err;
  EXPECT_EQ(runCli({"find-fiducials", "--screws", "a.stl", "--bone", "b.stl", "--count", "0"}).exit_code, 2);
}

// Two Line markups written as Slicer does, in RAS: the reader converts to LPS.
void writeLines(const std::filesystem::path& path) {
  const auto line = [](const std::string& name, const Eigen::Vector3d& a_lps, const Eigen::Vector3d& b_lps,
                       const std::string& description) {
    nlohmann::json cps = nlohmann::json::array();
    for (const auto& p : {a_lps, b_lps}) {
      cps.push_back({{"id", "1"},
                     {"label", name},
                     {"description", description},
                     {"position", {-p.x(), -p.y(), p.z()}},
                     {"positionStatus", "defined"}});
    }
    return nlohmann::json{{"type", "Line"}, {"name", name}, {"coordinateSystem", "RAS"}, {"controlPoints", cps}};
  };
  nlohmann::json doc;
  doc["@schema"] =
      "https://raw.githubusercontent.com/slicer/slicer/master/Modules/Loadable/Markups/Resources/Schema/"
      "markups-schema-v1.0.3.json#";
  doc["markups"] = {line("C5 left", {10, 0, 8}, {10, 20, 8}, "vertebra=C5; diameter_mm=3"),
                    line("C5 right", {-10, 0, 10}, {-10, 0, -10}, "vertebra=C5; diameter_mm=4; length_mm=20")};
  std::ofstream(path) << doc.dump(2);
}

TEST(CliPlanCheck, ReportsClearanceOfEachPathToThePlane) {
  const auto dir = scratchDirectory("plan");
  TriangleMesh plane;
  plane.vertices.resize(4, 3);
  plane.vertices << -100, -100, 0, 100, -100, 0, 100, 100, 0, -100, 100, 0;
  plane.faces.resize(2, 3);
  plane.faces << 0, 1, 2, 0, 2, 3;
  writeObj(plane, dir / "plane.obj");
  writeLines(dir / "paths.mrk.json");
  const auto r = runCli({"plan-check", "--paths", (dir / "paths.mrk.json").string(), "--surface",
                         (dir / "plane.obj").string(), "--json"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const auto json = nlohmann::json::parse(r.out);
  ASSERT_EQ(json["paths"].size(), 2u);
  const auto& left = json["paths"][0];
  EXPECT_EQ(left["vertebra"].get<std::string>(), "C5");
  EXPECT_NEAR(left["entry_mm"][0].get<double>(), 10.0, 1e-9);  // LPS again
  EXPECT_NEAR(left["min_clearance_mm"].get<double>(), 8.0 - 1.5, 1e-6);
  EXPECT_EQ(left["profile"].size(), 21u);
  EXPECT_FALSE(left["cuts_surface"].get<bool>());
  const auto& right = json["paths"][1];
  EXPECT_TRUE(right["cuts_surface"].get<bool>());
  EXPECT_NEAR(right["min_clearance_mm"].get<double>(), -2.0, 1e-6);
  EXPECT_NEAR(right["crossings_mm"][0].get<double>(), 10.0, 1e-6);
  EXPECT_EQ(json["paths_cutting_surface"].get<int>(), 1);
}

TEST(CliPlanCheck, FileWithoutLinesIsRefused) {
  const auto dir = scratchDirectory("plan");
  std::ofstream(dir / "points.mrk.json")
      << R"({"markups":[{"type":"Fiducial","controlPoints":[{"label":"F-1","position":[1,2,3]}]}]})";
  writeObj(vertebraLikeMesh(11, 12), dir / "s.obj");
  const auto r = runCli(
      {"plan-check", "--paths", (dir / "points.mrk.json").string(), "--surface", (dir / "s.obj").string(), "--json"});
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find("Line"), std::string::npos) << r.err;
}

}  // namespace
}  // namespace mrsns::test
