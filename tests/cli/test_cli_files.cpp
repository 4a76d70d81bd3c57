// mrsns-cli info/convert on images, meshes, landmarks and transforms.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <Eigen/Core>
#include <algorithm>
#include <fstream>
#include <nlohmann/json.hpp>
#include <vector>

#include "cli_runner.h"
#include "test_data.h"

namespace mrsns::test {
namespace {

using ::testing::HasSubstr;
using Json = nlohmann::json;

void writeText(const std::filesystem::path& path, const std::string& text) {
  std::ofstream out(path, std::ios::binary);
  out << text;
}

Json infoJson(const std::filesystem::path& file) {
  const CliResult r = runCli({"info", "--json", file.string()});
  EXPECT_EQ(r.exit_code, 0) << r.err;
  return Json::parse(r.out);
}

/// Exit 1 and exactly one stderr line naming the file.
void expectOneLineFailure(const std::vector<std::string>& args, const std::string& name) {
  const CliResult r = runCli(args);
  EXPECT_EQ(r.exit_code, 1) << r.out;
  EXPECT_THAT(r.err, HasSubstr(name));
  ASSERT_FALSE(r.err.empty());
  EXPECT_EQ(r.err.find('\n'), r.err.size() - 1) << r.err;
  EXPECT_TRUE(r.out.empty()) << r.out;
}

TEST(CliFiles, InfoOnDicomSeriesFolder) {
  MRSNS_REQUIRE_DATA(folder, "ct/totalsegmentator/example_ct_dicom");
  const Json j = infoJson(folder);
  EXPECT_EQ(j["kind"], "image");
  EXPECT_EQ(j["format"], "dicom");
  EXPECT_EQ(j["size"], Json::parse("[512, 512, 20]"));
  EXPECT_DOUBLE_EQ(j["spacing"][0].get<double>(), 0.9765625);
  EXPECT_NEAR(j["spacing"][2].get<double>(), 2.0, 1e-9);
  // ImagePositionPatient of the lowest slice (gdcmdump).
  EXPECT_NEAR(j["origin"][0].get<double>(), -249.51171875, 1e-9);
  EXPECT_NEAR(j["origin"][1].get<double>(), -437.51171875, 1e-9);
  EXPECT_NEAR(j["origin"][2].get<double>(), -804.5, 1e-9);
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) EXPECT_NEAR(j["direction"][r][c].get<double>(), r == c ? 1.0 : 0.0, 1e-12);
  }
  EXPECT_EQ(j["dicom_files"], 20);
  EXPECT_NEAR(j["physical_extent_mm"][0].get<double>(), 500.0, 1e-9);
  EXPECT_FALSE(j.contains("labels"));  // a CT in HU has far more than 256 values
  // The folder's series, each with what a user chooses it by (never the patient's name).
  EXPECT_EQ(j["modality"], "CT");
  EXPECT_EQ(j["series_description"], "CT Body 3.0");
  ASSERT_EQ(j["series"].size(), 1U);
  const Json& s = j["series"][0];
  EXPECT_EQ(s["index"], 1);
  EXPECT_EQ(s["uid"], j["series_id"]);
  EXPECT_EQ(s["modality"], "CT");
  EXPECT_EQ(s["description"], "CT Body 3.0");
  EXPECT_EQ(s["files"], 20);
  EXPECT_EQ(s["rows"], 512);
  EXPECT_EQ(s["columns"], 512);
  EXPECT_EQ(s["study_date"], "20221208");
  EXPECT_TRUE(s["read"].get<bool>());
  EXPECT_EQ(j.dump().find("patient_name"), std::string::npos);
}

TEST(CliFiles, InfoOnVerseLabelMap) {
  MRSNS_REQUIRE_DATA(map, "ct/verse/sub-verse004_seg-vert_msk.nii.gz");
  const Json j = infoJson(map);
  EXPECT_EQ(j["format"], "nifti");
  EXPECT_EQ(j["size"], Json::parse("[161, 338, 61]"));
  // The header's sform offset (-77.694, 218.0015, -808.578) in RAS, in LPS.
  EXPECT_NEAR(j["origin"][0].get<double>(), 77.694, 1e-3);
  EXPECT_NEAR(j["origin"][1].get<double>(), -218.0015, 1e-3);
  EXPECT_NEAR(j["origin"][2].get<double>(), -808.578, 1e-3);
  // sform column 3 is (1.999, 0.0717, 1.4e-7) RAS for 2.0003 mm: -z of LPS... direction row 0, col 2 = -0.99936.
  EXPECT_NEAR(j["direction"][0][2].get<double>(), -1.9990110397 / 2.000296, 1e-4);
  ASSERT_TRUE(j.contains("labels"));
  std::vector<int> values;
  for (const auto& l : j["labels"]) {
    values.push_back(l["value"].get<int>());
    const double ml = l["voxels"].get<double>() * 1.0 * 1.0 * 2.000296 / 1000.0;
    EXPECT_NEAR(l["volume_ml"].get<double>(), ml, 1e-3 * ml);
  }
  EXPECT_EQ(values, (std::vector<int>{0, 16, 17, 18, 19, 20, 21, 22, 23, 24}));
}

TEST(CliFiles, ConvertStlToVtpKeepsTheMesh) {
  MRSNS_REQUIRE_DATA(stl, "ssm/scalismo/0.stl");
  const auto dir = scratchDirectory("cli");
  const CliResult r = runCli({"convert", "--json", stl.string(), (dir / "0.vtp").string()});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(Json::parse(r.out)["written"], (dir / "0.vtp").string());
  const Json a = infoJson(stl);
  const Json b = infoJson(dir / "0.vtp");
  EXPECT_EQ(a["vertices"], 1400);
  EXPECT_EQ(a["faces"], 2800);
  EXPECT_EQ(b["vertices"], a["vertices"]);
  EXPECT_EQ(b["faces"], a["faces"]);
  EXPECT_EQ(b["closed"], a["closed"]);
  EXPECT_NEAR(b["surface_area_mm2"].get<double>(), a["surface_area_mm2"].get<double>(), 1e-6);
}

TEST(CliFiles, MeshInfoMeasuresACube) {
  const auto dir = scratchDirectory("cli");
  // A 10 mm cube as ASCII STL, outward normals: 600 mm^2, 1 ml.
  const double v[8][3] = {{0, 0, 0},  {10, 0, 0},  {10, 10, 0},  {0, 10, 0},
                          {0, 0, 10}, {10, 0, 10}, {10, 10, 10}, {0, 10, 10}};
  const int f[12][3] = {{0, 2, 1}, {0, 3, 2}, {4, 5, 6}, {4, 6, 7}, {0, 1, 5}, {0, 5, 4},
                        {1, 2, 6}, {1, 6, 5}, {2, 3, 7}, {2, 7, 6}, {3, 0, 4}, {3, 4, 7}};
  std::string stl = "solid cube\n";
  for (const auto& t : f) {
    stl += "facet normal 0 0 0\nouter loop\n";
    for (int k : t)
      stl += "vertex " + std::to_string(v[k][0]) + " " + std::to_string(v[k][1]) + " " + std::to_string(v[k][2]) + "\n";
    stl += "endloop\nendfacet\n";
  }
  stl += "endsolid cube\n";
  writeText(dir / "cube.stl", stl);
  const Json j = infoJson(dir / "cube.stl");
  EXPECT_EQ(j["vertices"], 8);
  EXPECT_EQ(j["faces"], 12);
  EXPECT_TRUE(j["closed"].get<bool>());
  EXPECT_NEAR(j["surface_area_mm2"].get<double>(), 600.0, 1e-9);
  EXPECT_NEAR(j["volume_ml"].get<double>(), 1.0, 1e-12);
  EXPECT_TRUE(j["outward_oriented"].get<bool>());
}

TEST(CliFiles, ConvertFcsvToMarkupsJson) {
  const auto dir = scratchDirectory("cli");
  writeText(dir / "in.fcsv",
            "# Markups fiducial file version = 4.11\n# CoordinateSystem = RAS\n"
            "# columns = id,x,y,z,ow,ox,oy,oz,vis,sel,lock,label,desc,associatedNodeID\n"
            "a,1,2,3,0,0,0,1,1,1,0,Nasion,,\nb,-4,5.5,6,0,0,0,1,1,0,0,Tragus,left ear,\n");
  const CliResult r = runCli({"convert", (dir / "in.fcsv").string(), (dir / "out.mrk.json").string()});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const Json j = infoJson(dir / "out.mrk.json");
  EXPECT_EQ(j["count"], 2);
  EXPECT_EQ(j["coordinate_system_read"], "LPS");
  EXPECT_EQ(j["points"][0]["label"], "Nasion");
  // RAS (1, 2, 3) is LPS (-1, -2, 3).
  EXPECT_EQ(j["points"][0]["position"], Json::parse("[-1.0, -2.0, 3.0]"));
  EXPECT_EQ(j["points"][1]["position"], Json::parse("[4.0, -5.5, 6.0]"));
  EXPECT_FALSE(j["points"][1]["selected"].get<bool>());
  EXPECT_EQ(j["points"][1]["description"], "left ear");
  // The JSON is a Slicer markups file.
  std::ifstream in(dir / "out.mrk.json");
  const Json doc = Json::parse(in);
  EXPECT_THAT(doc["@schema"].get<std::string>(), HasSubstr("markups-schema-v1.0"));
  EXPECT_EQ(doc["markups"][0]["coordinateSystem"], "LPS");
  EXPECT_EQ(doc["markups"][0]["type"], "Fiducial");
}

/// Rows of a 4x4 as `info` prints them.
Eigen::Matrix4d filesRowsMatrix(const Json& rows) {
  Eigen::Matrix4d m;
  for (int r = 0; r < 4; ++r) {
    for (int c = 0; c < 4; ++c) m(r, c) = rows[static_cast<std::size_t>(r)][static_cast<std::size_t>(c)].get<double>();
  }
  return m;
}

/// The 16 numbers of a plain text matrix, read by hand.
Eigen::Matrix4d filesPlainMatrix(const std::filesystem::path& path) {
  std::ifstream in(path);
  std::vector<double> v;
  double x = 0.0;
  while (in >> x) v.push_back(x);
  EXPECT_EQ(v.size(), 16U) << path;
  Eigen::Matrix4d m = Eigen::Matrix4d::Identity();
  for (std::size_t i = 0; i < std::min<std::size_t>(v.size(), 16); ++i) m(i / 4, i % 4) = v[i];
  return m;
}

TEST(CliFiles, TransformInfoAndConversion) {
  const auto dir = scratchDirectory("cli");
  // The node MToWorld: 90 deg about z, translation (3, 4, 0), as a plain matrix (parent_T_child).
  writeText(dir / "m.txt", "0 -1 0 3\n1 0 0 4\n0 0 1 0\n0 0 0 1\n");
  Eigen::Matrix4d m;
  m << 0, -1, 0, 3, 1, 0, 0, 4, 0, 0, 1, 0, 0, 0, 0, 1;
  const CliResult r = runCli({"convert", (dir / "m.txt").string(), (dir / "m.tfm").string()});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const Json j = infoJson(dir / "m.tfm");
  EXPECT_EQ(j["kind"], "transform");
  EXPECT_EQ(j["format"], "itk-text");
  EXPECT_TRUE(j["is_rigid"].get<bool>());
  EXPECT_NEAR(j["rotation_angle_deg"].get<double>(), 90.0, 1e-9);
  EXPECT_NEAR(j["translation_norm_mm"].get<double>(), 5.0, 1e-12);
  // The .tfm holds the inverse (3D Slicer's convention): R^T and -R^T t = (-4, 3, 0), exact in binary.
  Eigen::Matrix4d inverse;
  inverse << 0, 1, 0, -4, -1, 0, 0, 3, 0, 0, 1, 0, 0, 0, 0, 1;
  EXPECT_LT((filesRowsMatrix(j["matrix"]) - inverse).cwiseAbs().maxCoeff(), 1e-15);
  EXPECT_LT((filesRowsMatrix(j["child_to_parent"]) - m).cwiseAbs().maxCoeff(), 1e-15);
  // What Slicer displays (RAS): x and y flipped, F M F.
  const Eigen::Matrix4d flip = Eigen::Vector4d(-1, -1, 1, 1).asDiagonal();
  EXPECT_LT((filesRowsMatrix(j["slicer_to_parent_ras"]) - flip * m * flip).cwiseAbs().maxCoeff(), 1e-15);
  // The plain matrix's info: the raw matrix is the ChildToParent itself.
  const Json plain = infoJson(dir / "m.txt");
  EXPECT_EQ(plain["format"], "matrix-text");
  EXPECT_EQ(plain["matrix"], plain["child_to_parent"]);
}

TEST(CliFiles, ConvertKeepsTheMeaningOfATransformAcrossConventions) {
  const auto dir = scratchDirectory("cli");
  // What 3D Slicer saves for a node whose ToParent in LPS is M = [Rz(90) | (-10, -20, 30)]:
  // inverse(M) = [0 1 0; -1 0 0; 0 0 1 | (20, -10, -30)].
  writeText(dir / "NodeToWorld.tfm",
            "#Insight Transform File V1.0\n#Transform 0\nTransform: AffineTransform_double_3_3\n"
            "Parameters: 0 1 0 -1 0 0 0 0 1 20 -10 -30\nFixedParameters: 0 0 0\n");
  Eigen::Matrix4d m;
  m << 0, -1, 0, -10, 1, 0, 0, -20, 0, 0, 1, 30, 0, 0, 0, 1;
  // .tfm -> .txt: the plain matrix is M (it used to be the file's numbers, the inverse).
  ASSERT_EQ(runCli({"convert", (dir / "NodeToWorld.tfm").string(), (dir / "NodeToWorld.txt").string()}).exit_code, 0);
  EXPECT_LT((filesPlainMatrix(dir / "NodeToWorld.txt") - m).cwiseAbs().maxCoeff(), 1e-15);
  // .txt -> .h5 -> .tfm: back to Slicer's numbers.
  ASSERT_EQ(runCli({"convert", (dir / "NodeToWorld.txt").string(), (dir / "NodeToWorld.h5").string()}).exit_code, 0);
  ASSERT_EQ(runCli({"convert", (dir / "NodeToWorld.h5").string(), (dir / "back.tfm").string()}).exit_code, 0);
  const Json back = infoJson(dir / "back.tfm");
  Eigen::Matrix4d slicer_numbers;
  slicer_numbers << 0, 1, 0, 20, -1, 0, 0, -10, 0, 0, 1, -30, 0, 0, 0, 1;
  EXPECT_LT((filesRowsMatrix(back["matrix"]) - slicer_numbers).cwiseAbs().maxCoeff(), 1e-14);
  EXPECT_LT((filesRowsMatrix(back["child_to_parent"]) - m).cwiseAbs().maxCoeff(), 1e-14);
  // An affine (an ImageToProbe with 0.1 mm/pixel) keeps its meaning through .txt -> .tfm -> .txt.
  writeText(dir / "ImageToProbe.txt", "0 -0.1 0 12.5\n0.1 0 0 -30\n0 0 1 2\n0 0 0 1\n");
  ASSERT_EQ(runCli({"convert", (dir / "ImageToProbe.txt").string(), (dir / "ImageToProbe.tfm").string()}).exit_code, 0);
  ASSERT_EQ(runCli({"convert", (dir / "ImageToProbe.tfm").string(), (dir / "again.txt").string()}).exit_code, 0);
  // Two inversions of a 0.1-scaled matrix (condition 10): a few ulps of 300 (entries of the inverse).
  EXPECT_LT((filesPlainMatrix(dir / "again.txt") - filesPlainMatrix(dir / "ImageToProbe.txt")).cwiseAbs().maxCoeff(),
            1e-12);
  const Json affine = infoJson(dir / "ImageToProbe.tfm");
  EXPECT_FALSE(affine["is_rigid"].get<bool>());
  // The ITK file's 3x3 is the inverse: 10 px per mm.
  EXPECT_NEAR(affine["matrix"][0][1].get<double>(), 10.0, 1e-12);
}

TEST(CliFiles, CorruptInputsExitOneWithOneLineNamingTheFile) {
  const auto dir = scratchDirectory("cli");
  writeText(dir / "garbage.stl", std::string(300, '\x13') + "garbage");
  expectOneLineFailure({"info", (dir / "garbage.stl").string()}, "garbage.stl");
  expectOneLineFailure({"info", "--json", (dir / "garbage.stl").string()}, "garbage.stl");
  expectOneLineFailure({"convert", (dir / "garbage.stl").string(), (dir / "out.vtp").string()}, "garbage.stl");
  writeText(dir / "short.nrrd",
            "NRRD0004\ntype: short\ndimension: 3\nsizes: 20 20 20\nencoding: raw\n\n" + std::string(100, '\0'));
  expectOneLineFailure({"info", (dir / "short.nrrd").string()}, "short.nrrd");
  writeText(dir / "empty.mrk.json", R"({"markups": [{"type": "Fiducial", "controlPoints": []}]})");
  expectOneLineFailure({"info", (dir / "empty.mrk.json").string()}, "empty.mrk.json");
  writeText(dir / "bad.tfm", "#Insight Transform File V1.0\nTransform: AffineTransform_double_3_3\nParameters: 1\n");
  expectOneLineFailure({"info", (dir / "bad.tfm").string()}, "bad.tfm");
}

}  // namespace
}  // namespace mrsns::test
