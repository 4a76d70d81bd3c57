#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <fstream>

#include "mrsns/core/error.h"
#include "mrsns/io/landmarks_io.h"
#include "test_data.h"

namespace mrsns::io {
namespace {

using ::testing::HasSubstr;

void writeText(const std::filesystem::path& path, const std::string& text) {
  std::ofstream out(path, std::ios::binary);
  out << text;
}

LandmarkSet sampleSet() {
  LandmarkSet set;
  set.name = "sample";
  set.points.push_back({"F-1", Eigen::Vector3d(1.5, -2.25, 3.125), true, true, false, "tip"});
  set.points.push_back({"Nasion, left", Eigen::Vector3d(-10.0, 20.0, -30.0), false, true, true, "quoted \"desc\""});
  set.points.push_back({"P3", Eigen::Vector3d(0.1, 0.2, 0.3), true, false, false, ""});
  return set;
}

void expectSamePoints(const LandmarkSet& a, const LandmarkSet& b, bool flags) {
  ASSERT_EQ(a.points.size(), b.points.size());
  for (std::size_t i = 0; i < a.points.size(); ++i) {
    EXPECT_EQ(a.points[i].label, b.points[i].label);
    // Written with 17 significant digits: exact round trip.
    EXPECT_TRUE(a.points[i].position.isApprox(b.points[i].position, 1e-15)) << i;
    if (flags) {
      EXPECT_EQ(a.points[i].selected, b.points[i].selected) << i;
      EXPECT_EQ(a.points[i].visible, b.points[i].visible) << i;
      EXPECT_EQ(a.points[i].locked, b.points[i].locked) << i;
      EXPECT_EQ(a.points[i].description, b.points[i].description) << i;
    }
  }
}

TEST(LandmarksIo, MarkupsJsonRoundTripKeepsLabelsFlagsAndLpsPositions) {
  const auto dir = test::scratchDirectory("lm");
  const auto file = dir / "points.mrk.json";
  writeMarkupsJson(sampleSet(), file);
  const LandmarksReadResult read = readLandmarksFile(file);
  EXPECT_EQ(read.info.format, "mrk.json");
  EXPECT_EQ(read.info.coordinate_system, "LPS");
  EXPECT_EQ(read.info.markup_type, "Fiducial");
  expectSamePoints(sampleSet(), read.landmarks, true);
}

TEST(LandmarksIo, MarkupsJsonInRasIsConvertedToLps) {
  const auto dir = test::scratchDirectory("lm");
  const auto file = dir / "ras.mrk.json";
  writeText(file, R"({"@schema": "x", "markups": [{"type": "Line", "coordinateSystem": "RAS",
      "controlPoints": [{"id": "1", "label": "L-1", "position": [10.0, -20.0, 30.0]},
                        {"id": "2", "label": "L-2", "position": [-1.0, 2.0, -3.0], "selected": false}]}]})");
  const LandmarksReadResult read = readLandmarksFile(file);
  EXPECT_EQ(read.info.coordinate_system, "RAS");
  EXPECT_EQ(read.info.markup_type, "Line");
  ASSERT_EQ(read.landmarks.size(), 2U);
  EXPECT_EQ(read.landmarks.points[0].position, Eigen::Vector3d(-10.0, 20.0, 30.0));
  EXPECT_EQ(read.landmarks.points[1].position, Eigen::Vector3d(1.0, -2.0, -3.0));
  EXPECT_FALSE(read.landmarks.points[1].selected);
  EXPECT_TRUE(read.landmarks.points[1].visible);
}

TEST(LandmarksIo, FcsvRoundTripIncludingQuotedLabels) {
  const auto dir = test::scratchDirectory("lm");
  const auto file = dir / "points.fcsv";
  writeFcsv(sampleSet(), file);
  const LandmarksReadResult read = readLandmarksFile(file);
  EXPECT_EQ(read.info.format, "fcsv");
  EXPECT_EQ(read.info.coordinate_system, "LPS");
  expectSamePoints(sampleSet(), read.landmarks, true);
}

TEST(LandmarksIo, LegacyFcsvCoordinateSystemCodesAndDefaults) {
  const auto dir = test::scratchDirectory("lm");
  // Slicer 4.6-4.10: numeric code 0 means RAS.
  writeText(dir / "ras.fcsv",
            "# Markups fiducial file version = 4.6\n# CoordinateSystem = 0\n"
            "# columns = id,x,y,z,ow,ox,oy,oz,vis,sel,lock,label,desc,associatedNodeID\n"
            "vtkMRMLMarkupsFiducialNode_1,1,2,3,0,0,0,1,1,0,1,A,desc a,\n");
  const auto ras = readLandmarksFile(dir / "ras.fcsv");
  EXPECT_EQ(ras.info.coordinate_system, "RAS");
  ASSERT_EQ(ras.landmarks.size(), 1U);
  EXPECT_EQ(ras.landmarks.points[0].position, Eigen::Vector3d(-1, -2, 3));
  EXPECT_FALSE(ras.landmarks.points[0].selected);
  EXPECT_TRUE(ras.landmarks.points[0].locked);
  EXPECT_EQ(ras.landmarks.points[0].description, "desc a");
  // No CoordinateSystem line in a Slicer file: RAS (what Slicer meant before 4.11).
  writeText(dir / "old.fcsv",
            "# Markups fiducial file version = 4.4\n"
            "# columns = id,x,y,z,ow,ox,oy,oz,vis,sel,lock,label,desc,associatedNodeID\n"
            "id0,4,5,6,0,0,0,1,1,1,0,B,,\n");
  EXPECT_EQ(readLandmarks(dir / "old.fcsv").points[0].position, Eigen::Vector3d(-4, -5, 6));
  // Code 1 is LPS.
  writeText(dir / "lps.fcsv",
            "# Markups fiducial file version = 4.11\n# CoordinateSystem = 1\nid0,4,5,6,0,0,0,1,1,1,0,C,,\n");
  EXPECT_EQ(readLandmarks(dir / "lps.fcsv").points[0].position, Eigen::Vector3d(4, 5, 6));
}

TEST(LandmarksIo, CsvRoundTrip) {
  const auto dir = test::scratchDirectory("lm");
  writeLandmarks(sampleSet(), dir / "points.csv");
  const auto read = readLandmarksFile(dir / "points.csv");
  EXPECT_EQ(read.info.coordinate_system, "unspecified");
  expectSamePoints(sampleSet(), read.landmarks, false);
}

TEST(LandmarksIo, StatismoHandLandmarksCsvAndFcsvAgree) {
  MRSNS_REQUIRE_DATA(csv, "ssm/statismo/hand_landmarks/hand-1.csv");
  MRSNS_REQUIRE_DATA(fcsv, "ssm/statismo/hand_landmarks/hand-1.fcsv");
  const LandmarkSet a = readLandmarks(csv);
  const LandmarkSet b = readLandmarks(fcsv);
  // pt1..pt9 in the CSV; the same nine positions as "x y z" lines in the .fcsv.
  ASSERT_EQ(a.size(), 9U);
  ASSERT_EQ(b.size(), 9U);
  EXPECT_EQ(a.points[0].label, "pt1");
  EXPECT_EQ(a.points[0].position, Eigen::Vector3d(296, 56, 0));
  for (std::size_t i = 0; i < a.size(); ++i) EXPECT_EQ(a.points[i].position, b.points[i].position) << i;
  MRSNS_REQUIRE_DATA(fcsv2, "ssm/statismo/hand_landmarks/hand-2.fcsv");
  EXPECT_GE(readLandmarks(fcsv2).size(), 8U);
}

TEST(LandmarksIo, FemurLandmarksCsv) {
  MRSNS_REQUIRE_DATA(csv, "ssm/statismo/femur_meshes/VSD001-lm.csv");
  const LandmarkSet set = readLandmarks(csv);
  ASSERT_EQ(set.size(), 4U);
  EXPECT_EQ(set.points[0].label, "A");
  EXPECT_EQ(set.points[3].label, "D");
  EXPECT_NEAR(set.points[2].position.z(), 159.55093, 1e-9);
}

TEST(LandmarksIo, MalformedFilesGiveFormatErrorsNamingTheFile) {
  const auto dir = test::scratchDirectory("lm");
  struct Case {
    std::string name;
    std::string text;
    std::string what;
  };
  const std::vector<Case> cases = {
      {"no_points.mrk.json", R"({"markups": [{"type": "Fiducial", "coordinateSystem": "LPS", "controlPoints": []}]})",
       "no control points"},
      {"no_markups.mrk.json", R"({"@schema": "x"})", "no \"markups\""},
      {"broken.mrk.json", R"({"markups": [ {"type": )", "not valid JSON"},
      {"bad_pos.mrk.json", R"({"markups": [{"controlPoints": [{"position": [1, 2]}]}]})", "3 numbers"},
      {"bad.fcsv", "# Markups fiducial file version = 4.11\nid0,1,x,3,0,0,0,1,1,1,0,A,,\n", "line 2"},
      {"empty.csv", "\n\n", "no points"},
  };
  for (const auto& c : cases) {
    writeText(dir / c.name, c.text);
    try {
      (void)readLandmarks(dir / c.name);
      ADD_FAILURE() << c.name << " was accepted";
    } catch (const FormatError& e) {
      EXPECT_THAT(e.what(), HasSubstr(c.name));
      EXPECT_THAT(e.what(), HasSubstr(c.what));
    }
  }
  writeText(dir / "ijk.fcsv", "# Markups fiducial file version = 4.11\n# CoordinateSystem = 2\nid0,1,2,3\n");
  EXPECT_THROW((void)readLandmarks(dir / "ijk.fcsv"), UnsupportedError);
  EXPECT_THROW((void)readLandmarks(dir / "missing.fcsv"), FileError);
}

}  // namespace
}  // namespace mrsns::io
