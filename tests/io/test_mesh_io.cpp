#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cstring>
#include <fstream>
#include <limits>
#include <random>

#include "mrsns/core/error.h"
#include "mrsns/io/mesh_io.h"
#include "test_data.h"

namespace mrsns::io {
namespace {

using ::mrsns::test::writeBytes;

using ::testing::HasSubstr;

/// A closed octahedron (6 vertices, 8 faces, outward counter-clockwise) with
/// unit normals and distinct colours.
TriangleMesh octahedron() {
  TriangleMesh m;
  m.vertices.resize(6, 3);
  m.vertices << 10.5, 0, 0, -10.5, 0, 0, 0, 20.25, 0, 0, -20.25, 0, 0, 0, 30.125, 0, 0, -30.125;
  m.vertices.rowwise() += Eigen::RowVector3d(100.0, -50.0, 7.0);
  m.faces.resize(8, 3);
  m.faces << 0, 2, 4, 2, 1, 4, 1, 3, 4, 3, 0, 4, 2, 0, 5, 1, 2, 5, 3, 1, 5, 0, 3, 5;
  m.normals.resize(6, 3);
  m.normals << 1, 0, 0, -1, 0, 0, 0, 1, 0, 0, -1, 0, 0, 0, 1, 0, 0, -1;
  m.colors.resize(6, 3);
  for (int i = 0; i < 6; ++i) m.colors.row(i) << i / 5.0, 1.0 - i / 5.0, (i % 2) * 1.0;
  return m;
}

/// Each face's corner coordinates must match (formats may renumber vertices,
/// e.g. STL merges them in first-use order, but keep face order and winding).
void expectSameFaces(const TriangleMesh& expected, const TriangleMesh& actual, double tolerance) {
  ASSERT_EQ(actual.faceCount(), expected.faceCount());
  for (Eigen::Index f = 0; f < expected.faceCount(); ++f) {
    for (int k = 0; k < 3; ++k) {
      const Eigen::RowVector3d a = expected.vertices.row(expected.faces(f, k));
      const Eigen::RowVector3d b = actual.vertices.row(actual.faces(f, k));
      EXPECT_LT((a - b).norm(), tolerance) << "face " << f << " corner " << k;
    }
  }
}

TEST(MeshIo, RoundTripEveryFormat) {
  const auto dir = test::scratchDirectory("mesh");
  const TriangleMesh mesh = octahedron();
  // STL stores float32: coordinates ~100 mm keep ~1e-5 mm; the others store doubles or float32 too.
  for (const std::string name : {"a.stl", "b.vtp", "c.vtk", "d.obj", "e.ply"}) {
    for (bool binary : {true, false}) {
      SCOPED_TRACE(name + (binary ? " binary" : " ascii"));
      const auto file = dir / ((binary ? "bin_" : "txt_") + name);
      writeMesh(mesh, file, {.binary = binary, .compress = binary});
      const TriangleMesh back = readMesh(file);
      EXPECT_EQ(back.vertexCount(), mesh.vertexCount());
      expectSameFaces(mesh, back, 1e-4);
      EXPECT_EQ(back.name, file.stem().string());
    }
  }
}

TEST(MeshIo, NormalsAndColoursSurviveWhereTheFormatHoldsThem) {
  const auto dir = test::scratchDirectory("mesh");
  const TriangleMesh mesh = octahedron();
  for (const std::string name : {"n.vtp", "n.vtk", "n.ply"}) {
    SCOPED_TRACE(name);
    writeMesh(mesh, dir / name);
    const TriangleMesh back = readMesh(dir / name);
    ASSERT_EQ(back.vertexCount(), 6);
    // Vertices are not renumbered by these formats.
    EXPECT_TRUE(back.vertices.isApprox(mesh.vertices, 1e-6));
    if (name != "n.ply") {
      ASSERT_EQ(back.normals.rows(), 6);
      EXPECT_TRUE(back.normals.isApprox(mesh.normals, 1e-6));
    }
    ASSERT_EQ(back.colors.rows(), 6);
    // Colours are stored as 8-bit: within half a step.
    EXPECT_LT((back.colors - mesh.colors).cwiseAbs().maxCoeff(), 0.5 / 255.0 + 1e-9);
  }
}

TEST(MeshIo, PolygonsAreTriangulated) {
  const auto dir = test::scratchDirectory("mesh");
  writeBytes(dir / "quad.obj", "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0 0 1\nf 1 2 3 4\nf 1 2 5\n");
  const TriangleMesh obj = readMesh(dir / "quad.obj");
  EXPECT_EQ(obj.faceCount(), 3);
  writeBytes(dir / "pentagon.vtk",
             "# vtk DataFile Version 3.0\npentagon\nASCII\nDATASET POLYDATA\nPOINTS 5 float\n"
             "0 0 0 2 0 0 3 2 0 1 3 0 -1 2 0\nPOLYGONS 1 6\n5 0 1 2 3 4\n");
  const TriangleMesh vtk = readMesh(dir / "pentagon.vtk");
  EXPECT_EQ(vtk.vertexCount(), 5);
  EXPECT_EQ(vtk.faceCount(), 3);
}

TEST(MeshIo, ScalismoStlMeshesInCorrespondence) {
  MRSNS_REQUIRE_DATA(first, "ssm/scalismo/0.stl");
  // Independent count: a binary STL's header holds its triangle count.
  std::ifstream in(first, std::ios::binary);
  char header[84];
  in.read(header, 84);
  std::uint32_t triangles = 0;
  std::memcpy(&triangles, header + 80, 4);
  const TriangleMesh a = readMesh(first);
  EXPECT_EQ(a.faceCount(), static_cast<Eigen::Index>(triangles));
  // The data README: 1400 points, 2800 triangles; merging shared corners must give back the 1400 points.
  EXPECT_EQ(a.vertexCount(), 1400);
  EXPECT_EQ(a.faceCount(), 2800);
  MRSNS_REQUIRE_DATA(other, "ssm/scalismo/6.stl");
  const TriangleMesh b = readMesh(other);
  EXPECT_EQ(b.faceCount(), a.faceCount());
  EXPECT_EQ(b.vertexCount(), a.vertexCount());
  EXPECT_TRUE(a.vertices.allFinite());
}

TEST(MeshIo, FemurAndHandLegacyPolydata) {
  MRSNS_REQUIRE_DATA(femur, "ssm/statismo/femur_meshes/VSD001_femur.vtk");
  const TriangleMesh f = readMesh(femur);
  EXPECT_EQ(f.vertexCount(), 18934);
  EXPECT_GT(f.faceCount(), 30000);
  EXPECT_GE(f.faces.minCoeff(), 0);
  EXPECT_LT(f.faces.maxCoeff(), f.vertexCount());
  // The femur landmarks lie on the surface: within a few mm of a vertex.
  const Eigen::RowVector3d landmark_a(585.142, 490.4251, -242.97441);
  EXPECT_LT((f.vertices.rowwise() - landmark_a).rowwise().norm().minCoeff(), 5.0);

  MRSNS_REQUIRE_DATA(hand, "ssm/statismo/hand_polydata/hand-0.vtk");
  const TriangleMesh h = readMesh(hand);
  // A 2D outline: 1590 points joined by lines, no triangles.
  EXPECT_EQ(h.vertexCount(), 1590);
  EXPECT_EQ(h.faceCount(), 0);
  EXPECT_NEAR(h.vertices.col(2).cwiseAbs().maxCoeff(), 0.0, 1e-9);
}

TEST(MeshIo, GarbageStlIsAFormatErrorNamingTheFile) {
  const auto dir = test::scratchDirectory("mesh");
  std::mt19937 rng(7);
  std::string garbage(5000, '\0');
  for (auto& c : garbage) c = static_cast<char>(rng() & 0xff);
  writeBytes(dir / "garbage.stl", garbage);
  writeBytes(dir / "text.stl", "this is not an STL file at all\n");
  writeBytes(dir / "empty.stl", "");
  writeBytes(dir / "nofacets.stl", "solid empty\nendsolid empty\n");
  for (const std::string name : {"garbage.stl", "text.stl", "empty.stl", "nofacets.stl"}) {
    try {
      (void)readMesh(dir / name);
      ADD_FAILURE() << name << " was accepted";
    } catch (const FormatError& e) {
      EXPECT_THAT(e.what(), HasSubstr(name));
    }
  }
}

TEST(MeshIo, TruncatedBinaryStlIsRefused) {
  const auto dir = test::scratchDirectory("mesh");
  writeMesh(octahedron(), dir / "full.stl");
  std::ifstream in(dir / "full.stl", std::ios::binary);
  std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  ASSERT_EQ(bytes.size(), 84U + 50U * 8U);
  writeBytes(dir / "cut.stl", bytes.substr(0, bytes.size() - 30));
  try {
    (void)readMesh(dir / "cut.stl");
    FAIL() << "a truncated STL was accepted";
  } catch (const FormatError& e) {
    EXPECT_THAT(e.what(), HasSubstr("cut.stl"));
    EXPECT_THAT(e.what(), HasSubstr("8 triangles"));
  }
}

TEST(MeshIo, GarbageInOtherFormatsIsAFormatError) {
  const auto dir = test::scratchDirectory("mesh");
  const std::string junk = "\x01\x02 garbage \xff\xfe not a mesh\n1 2 3\n";
  for (const std::string name : {"junk.vtp", "junk.vtk", "junk.ply", "junk.obj"}) {
    writeBytes(dir / name, junk);
    try {
      (void)readMesh(dir / name);
      ADD_FAILURE() << name << " was accepted";
    } catch (const FormatError& e) {
      EXPECT_THAT(e.what(), HasSubstr(name));
    }
  }
  // NaN coordinates in an otherwise valid file.
  writeBytes(dir / "nan.vtk",
             "# vtk DataFile Version 3.0\nnan\nASCII\nDATASET POLYDATA\nPOINTS 3 double\n0 0 0 nan 0 0 0 1 0\n"
             "POLYGONS 1 4\n3 0 1 2\n");
  EXPECT_THROW((void)readMesh(dir / "nan.vtk"), FormatError);
}

TEST(MeshIo, MissingFileUnknownExtensionAndBadMeshes) {
  const auto dir = test::scratchDirectory("mesh");
  EXPECT_THROW((void)readMesh(dir / "missing.stl"), FileError);
  EXPECT_THROW((void)readMesh(dir / "mesh.xyz"), UnsupportedError);
  TriangleMesh bad = octahedron();
  bad.faces(0, 0) = 6;
  EXPECT_THROW(writeMesh(bad, dir / "bad.vtp"), InvalidArgumentError);
  bad = octahedron();
  bad.vertices(1, 1) = std::numeric_limits<double>::quiet_NaN();
  EXPECT_THROW(writeMesh(bad, dir / "bad.stl"), InvalidArgumentError);
  EXPECT_THROW(writeMesh(octahedron(), dir / "no_such_folder" / "x.vtp"), FileError);
}

}  // namespace
}  // namespace mrsns::io
