// `mrsns-cli snapshot` through the real binary: meshes and planned paths to a
// PNG of the asked size, CT slices beside it, and refusals. Renders offscreen:
// skipped without an X display (CI runs ctest under xvfb-run -a).
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>

#include "cli_runner.h"
#include "mrsns/io/image_io.h"
#include "mrsns/io/mesh_io.h"
#include "test_data.h"

namespace mrsns::test {
namespace {

bool haveDisplay() {
  const char* d = std::getenv("DISPLAY");
  return d != nullptr && *d != '\0';
}

// Width and height from the PNG's IHDR chunk (big-endian at bytes 16..23),
// after checking the signature.
std::array<int, 2> pngSize(const std::filesystem::path& png) {
  std::ifstream in(png, std::ios::binary);
  unsigned char b[24] = {};
  in.read(reinterpret_cast<char*>(b), 24);
  const unsigned char signature[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
  if (!in || !std::equal(signature, signature + 8, b)) return {-1, -1};
  auto be32 = [&](int o) { return (b[o] << 24) | (b[o + 1] << 16) | (b[o + 2] << 8) | b[o + 3]; };
  return {be32(16), be32(20)};
}

// A closed box between two corners (12 outward triangles).
TriangleMesh box(const Eigen::Vector3d& lo, const Eigen::Vector3d& hi) {
  TriangleMesh m;
  m.vertices.resize(8, 3);
  for (int i = 0; i < 8; ++i) {
    m.vertices.row(i) =
        Eigen::RowVector3d((i & 1) ? hi.x() : lo.x(), (i & 2) ? hi.y() : lo.y(), (i & 4) ? hi.z() : lo.z());
  }
  m.faces.resize(12, 3);
  m.faces << 0, 2, 3, 0, 3, 1, 4, 5, 7, 4, 7, 6, 0, 1, 5, 0, 5, 4, 2, 6, 7, 2, 7, 3, 0, 4, 6, 0, 6, 2, 1, 3, 7, 1, 7, 5;
  return m;
}

}  // namespace

TEST(CliSnapshot, MeshesToAPngOfTheAskedSize) {
  if (!haveDisplay()) GTEST_SKIP() << "no X display: run under xvfb-run -a";
  const auto dir = scratchDirectory("snapshot");
  io::writeMesh(box(Eigen::Vector3d(-30, -5, -5), Eigen::Vector3d(-10, 5, 5)), dir / "a.stl");
  io::writeMesh(box(Eigen::Vector3d(10, -5, -5), Eigen::Vector3d(30, 5, 5)), dir / "b.vtp");
  const auto png = dir / "view.png";
  const auto r = runCli({"snapshot", "--mesh", (dir / "a.stl").string(), "--mesh", (dir / "b.vtp").string(), "--out",
                         png.string(), "--width", "320", "--height", "240", "--json"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const auto j = nlohmann::json::parse(r.out);
  EXPECT_EQ(j["verb"], "snapshot");
  EXPECT_EQ(j["png"], png.string());
  ASSERT_EQ(j["meshes"].size(), 2u);
  EXPECT_EQ(j["triangles"], j["meshes"][0]["triangles"].get<int>() + j["meshes"][1]["triangles"].get<int>());
  ASSERT_TRUE(std::filesystem::exists(png));
  EXPECT_EQ(pngSize(png), (std::array<int, 2>{320, 240}));
}

TEST(CliSnapshot, CtSlicesBesideTheMeshView) {
  if (!haveDisplay()) GTEST_SKIP() << "no X display: run under xvfb-run -a";
  const auto dir = scratchDirectory("snapshot");
  ImageVolume ct;
  ct.size = {40, 30, 20};
  ct.spacing = Eigen::Vector3d(1.0, 1.0, 2.0);
  ct.pixel_type = PixelType::Int16;
  ct.data.assign(ct.byteCount(), std::byte{0});
  io::writeImage(ct, dir / "ct.nrrd");
  io::writeMesh(box(Eigen::Vector3d(-10, -10, -10), Eigen::Vector3d(10, 10, 10)), dir / "a.stl");
  const auto r = runCli({"snapshot", "--mesh", (dir / "a.stl").string(), "--ct", (dir / "ct.nrrd").string(), "--out",
                         (dir / "view.png").string(), "--width", "300", "--height", "100", "--window", "800", "--level",
                         "100", "--json"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const auto j = nlohmann::json::parse(r.out);
  const std::filesystem::path slices = j["slices_png"].get<std::string>();
  EXPECT_EQ(slices, dir / "view_slices.png");
  EXPECT_EQ(j["ct"]["size"], nlohmann::json::array({40, 30, 20}));
  EXPECT_EQ(j["ct"]["window"], 800.0);
  EXPECT_EQ(pngSize(slices), (std::array<int, 2>{300, 100}));
  EXPECT_EQ(pngSize(dir / "view.png"), (std::array<int, 2>{300, 100}));
}

TEST(CliSnapshot, Refusals) {
  const auto dir = scratchDirectory("snapshot");
  // Usage errors (exit 2): nothing to draw, a size out of range, a missing file.
  EXPECT_EQ(runCli({"snapshot", "--out", (dir / "x.png").string()}).exit_code, 2);
  io::writeMesh(box(Eigen::Vector3d(-10, -10, -10), Eigen::Vector3d(10, 10, 10)), dir / "a.stl");
  EXPECT_EQ(runCli({"snapshot", "--mesh", (dir / "a.stl").string(), "--out", (dir / "x.png").string(), "--width", "5"})
                .exit_code,
            2);
  EXPECT_EQ(runCli({"snapshot", "--mesh", (dir / "missing.stl").string(), "--out", (dir / "x.png").string()}).exit_code,
            2);
  // A mesh file that is not a mesh: exit 1 with one line naming it.
  {
    std::ofstream bad(dir / "bad.stl");
    bad << "this is not an STL file";
  }
  const auto r = runCli({"snapshot", "--mesh", (dir / "bad.stl").string(), "--out", (dir / "x.png").string()});
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find("bad.stl"), std::string::npos) << r.err;
  EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
}

TEST(CliSnapshot, WithoutADisplayItSaysWhatToDo) {
  const auto dir = scratchDirectory("snapshot");
  io::writeMesh(box(Eigen::Vector3d(-10, -10, -10), Eigen::Vector3d(10, 10, 10)), dir / "a.stl");
  // env -u is not available through runCli; unset DISPLAY for the child.
  const char* saved = std::getenv("DISPLAY");
  const std::string keep = saved ? saved : "";
  ::unsetenv("DISPLAY");
  const auto r = runCli({"snapshot", "--mesh", (dir / "a.stl").string(), "--out", (dir / "x.png").string()});
  if (!keep.empty()) ::setenv("DISPLAY", keep.c_str(), 1);
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find("xvfb-run"), std::string::npos) << r.err;
}
}  // namespace mrsns::test
