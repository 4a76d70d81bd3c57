// Line markups (.mrk.json), the form a plan of screws is exchanged with 3D
// Slicer in: the writer against its reader, and both against what Slicer
// writes (markups schema v1.0.x: a "Line" markup with two control points,
// "coordinateSystem" RAS as Slicer 4.11 saves or LPS as Slicer 5 saves).
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <fstream>
#include <nlohmann/json.hpp>

#include "mrsns/core/error.h"
#include "mrsns/io/landmarks_io.h"
#include "mrsns/io/screw_path_io.h"
#include "test_data.h"

namespace mrsns::io {
namespace {

using ::testing::HasSubstr;

void writeMarkupsText(const std::filesystem::path& path, const std::string& text) {
  std::ofstream out(path, std::ios::binary);
  out << text;
}

std::vector<MarkupsLine> samplePlan() {
  return {{"C5 left", Eigen::Vector3d(12.25, 40.5, -103.125), Eigen::Vector3d(4.0, 8.0, -101.0),
           "vertebra=C5; side=left; diameter_mm=3.5; length_mm=26"},
          {"C5 right", Eigen::Vector3d(-12.0, 41.0, -103.0), Eigen::Vector3d(-4.5, 8.25, -100.5), ""}};
}

TEST(ScrewPathIo, WrittenPlanReadsBackExactlyWithNamesAndDescriptions) {
  const auto file = test::scratchDirectory("lines") / "plan.mrk.json";
  writeMarkupsLines(samplePlan(), file);
  const auto read = readMarkupsLines(file);
  ASSERT_EQ(read.size(), 2u);
  for (std::size_t i = 0; i < read.size(); ++i) {
    EXPECT_EQ(read[i].name, samplePlan()[i].name);
    EXPECT_EQ(read[i].start, samplePlan()[i].start) << "17 significant digits: exact";
    EXPECT_EQ(read[i].end, samplePlan()[i].end);
    EXPECT_EQ(read[i].description, samplePlan()[i].description);
  }
}

TEST(ScrewPathIo, WrittenFileIsWhatSlicerLoadsAsLineMarkups) {
  const auto file = test::scratchDirectory("lines") / "plan.mrk.json";
  writeMarkupsLines(samplePlan(), file);
  std::ifstream in(file);
  const auto doc = nlohmann::json::parse(in);
  EXPECT_THAT(doc["@schema"].get<std::string>(), HasSubstr("/Markups/Resources/Schema/markups-schema-v1.0."));
  ASSERT_EQ(doc["markups"].size(), 2u);
  const auto& line = doc["markups"][0];
  EXPECT_EQ(line["type"], "Line");
  EXPECT_EQ(line["coordinateSystem"], "LPS");
  EXPECT_EQ(line["coordinateUnits"], "mm");
  ASSERT_EQ(line["controlPoints"].size(), 2u);
  for (const auto& cp : line["controlPoints"]) {
    EXPECT_EQ(cp["positionStatus"], "defined");
    EXPECT_EQ(cp["position"].size(), 3u);
    // Slicer stores a control point's orientation as a 3x3 in the file's system: identity in RAS is
    // diag(-1, -1, 1) in LPS.
    EXPECT_EQ(cp["orientation"], nlohmann::json::array({-1.0, -0.0, -0.0, -0.0, -1.0, -0.0, 0.0, 0.0, 1.0}));
  }
  // Entry first, in LPS as written; Slicer shows the length measurement.
  EXPECT_EQ(line["controlPoints"][0]["position"], nlohmann::json::array({12.25, 40.5, -103.125}));
  EXPECT_NEAR(line["measurements"][0]["value"].get<double>(), (samplePlan()[0].end - samplePlan()[0].start).norm(),
              1e-12);
  // The generic markups reader sees the same points (one reader's LPS is the other's).
  const auto points = readLandmarksFile(file);
  EXPECT_EQ(points.info.markup_type, "Line");
  ASSERT_GE(points.landmarks.size(), 2u);
  EXPECT_EQ(points.landmarks.points[0].position, samplePlan()[0].start);
}

TEST(ScrewPathIo, SlicerRasLineIsReadInLps) {
  // A line as Slicer 4.11 saves it (RAS), with a fiducial list beside it that is not a plan.
  const auto file = test::scratchDirectory("lines") / "slicer411.mrk.json";
  writeMarkupsText(file, R"({"@schema": "https://raw.githubusercontent.com/slicer/slicer/master/Modules/Loadable/Markups/Resources/Schema/markups-schema-v1.0.0.json#",
    "markups": [
      {"type": "Fiducial", "coordinateSystem": "RAS", "controlPoints": [{"id": "1", "label": "F-1", "position": [1, 2, 3]}]},
      {"type": "Line", "name": "T12 right", "coordinateSystem": "RAS", "coordinateUnits": "mm",
       "controlPoints": [
         {"id": "1", "label": "T12 right-1", "description": "vertebra=T12; diameter_mm=5.5",
          "position": [10.0, -20.0, 30.0], "positionStatus": "defined"},
         {"id": "2", "label": "T12 right-2", "position": [2.5, -60.0, 31.0], "positionStatus": "defined"}]}]})");
  const auto read = readMarkupsLines(file);
  ASSERT_EQ(read.size(), 1u) << "the fiducial list is skipped";
  EXPECT_EQ(read[0].name, "T12 right");
  EXPECT_EQ(read[0].start, Eigen::Vector3d(-10.0, 20.0, 30.0));
  EXPECT_EQ(read[0].end, Eigen::Vector3d(-2.5, 60.0, 31.0));
  EXPECT_EQ(read[0].description, "vertebra=T12; diameter_mm=5.5") << "the first point's description, as Slicer keeps it";
}

TEST(ScrewPathIo, UnusableFilesAreRefusedNamingTheFileAndWhatToDo) {
  const auto dir = test::scratchDirectory("lines");
  writeMarkupsText(dir / "one_point.mrk.json",
            R"({"markups": [{"type": "Line", "controlPoints": [{"position": [0, 0, 0]},
                {"position": [1, 1, 1], "positionStatus": "undefined"}]}]})");
  try {
    (void)readMarkupsLines(dir / "one_point.mrk.json");
    FAIL() << "a line with one placed point was read";
  } catch (const FormatError& e) {
    EXPECT_THAT(e.what(), HasSubstr("one_point.mrk.json"));
    EXPECT_THAT(e.what(), HasSubstr("place entry and target"));
  }
  writeMarkupsText(dir / "ijk.mrk.json",
            R"({"markups": [{"type": "Line", "coordinateSystem": "IJK", "controlPoints": [{"position": [0, 0, 0]},
                {"position": [1, 1, 1]}]}]})");
  EXPECT_THROW((void)readMarkupsLines(dir / "ijk.mrk.json"), UnsupportedError);
  writeMarkupsText(dir / "points_only.mrk.json", R"({"markups": [{"type": "Fiducial", "controlPoints": []}]})");
  try {
    (void)readMarkupsLines(dir / "points_only.mrk.json");
    FAIL() << "a file without lines was read";
  } catch (const FormatError& e) {
    EXPECT_THAT(e.what(), HasSubstr("draw the paths as lines"));
  }
  writeMarkupsText(dir / "truncated.mrk.json", R"({"markups": [{"type": "Line", "controlPoi)");
  EXPECT_THROW((void)readMarkupsLines(dir / "truncated.mrk.json"), FormatError);
  EXPECT_THROW((void)readMarkupsLines(dir / "missing.mrk.json"), FileError);
  MarkupsLine bad{"bad", Eigen::Vector3d(0.0, std::nan(""), 0.0), Eigen::Vector3d::Ones(), ""};
  EXPECT_THROW(writeMarkupsLines({bad}, dir / "bad.mrk.json"), InvalidArgumentError);
  EXPECT_FALSE(std::filesystem::exists(dir / "bad.mrk.json")) << "nothing half-written";
}

}  // namespace
}  // namespace mrsns::io
