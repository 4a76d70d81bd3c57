// make-phantom and segment through the real binary: the phantom's files, bone
// from its CT, meshes from its label map and from a real TotalSegmentator
// label map, and refusals.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>

#include "cli_runner.h"
#include "test_data.h"

namespace mrsns::test {
namespace {

nlohmann::json parse(const CliResult& r) {
  EXPECT_EQ(r.exit_code, 0) << r.err;
  return nlohmann::json::parse(r.out);
}

nlohmann::json readJson(const std::filesystem::path& path) {
  std::ifstream in(path);
  return nlohmann::json::parse(in);
}

/// A coarse (1.5 mm) phantom, written once per test that needs it.
std::filesystem::path coarsePhantom(const std::string& name) {
  const auto dir = scratchDirectory(name);
  const auto r = runCli({"make-phantom", "--output", dir.string(), "--spacing", "1.5", "--seed", "3", "--json"});
  EXPECT_EQ(r.exit_code, 0) << r.err;
  return dir;
}

TEST(CliMakePhantom, WritesVolumesMeshesGroundTruthAndManifest) {
  const auto dir = scratchDirectory("phantom");
  const auto j = parse(runCli({"make-phantom", "--output", dir.string(), "--spacing", "1.0", "--json"}));
  EXPECT_EQ(j["verb"], "make-phantom");
  EXPECT_EQ(j["size"], nlohmann::json::array({120, 120, 140}));
  for (const char* f : {"phantom_ct.nrrd", "phantom_labels.nrrd", "fiducials_truth.mrk.json", "screw_paths.mrk.json",
                        "phantom.json", "C3.stl", "C7.stl", "carotid_artery.stl", "fiducial_screws.stl"}) {
    EXPECT_TRUE(std::filesystem::is_regular_file(dir / f)) << f;
  }
  ASSERT_EQ(j["meshes"].size(), 7U);
  for (const auto& m : j["meshes"]) {
    SCOPED_TRACE(m["name"].get<std::string>());
    EXPECT_TRUE(m["closed"].get<bool>());
    EXPECT_NEAR(m["volume_ml"].get<double>(), m["voxel_volume_ml"].get<double>(),
                m["volume_tolerance_ml"].get<double>());
  }
  const auto manifest = readJson(dir / "phantom.json");
  EXPECT_EQ(manifest["fiducial_screws"].size(), 8U);
  EXPECT_EQ(manifest["screw_paths"].size(), 4U);
  EXPECT_EQ(manifest["labels"]["5"], "C5");
  EXPECT_EQ(manifest["labels"]["92"], "fiducial_screws");
  EXPECT_NE(manifest["command"].get<std::string>().find("make-phantom"), std::string::npos);
  // Slicer markups: 8 fiducials in LPS, and one line per screw path.
  const auto fiducials = readJson(dir / "fiducials_truth.mrk.json");
  const auto& markup = fiducials["markups"][0];
  EXPECT_EQ(markup["coordinateSystem"], "LPS");
  ASSERT_EQ(markup["controlPoints"].size(), 8U);
  const auto& first = markup["controlPoints"][0]["position"];
  const auto& truth = manifest["fiducial_screws"][0]["bone_entry"];
  for (int a = 0; a < 3; ++a) EXPECT_NEAR(first[a].get<double>(), truth[a].get<double>(), 1e-6);
  const auto lines = readJson(dir / "screw_paths.mrk.json");
  ASSERT_EQ(lines["markups"].size(), 4U);
  EXPECT_EQ(lines["markups"][0]["type"], "Line");
  // Same seed, same files.
  const auto again = scratchDirectory("phantom_again");
  parse(runCli({"make-phantom", "--output", again.string(), "--spacing", "1.0", "--json"}));
  std::ifstream a(dir / "phantom_ct.nrrd", std::ios::binary), b(again / "phantom_ct.nrrd", std::ios::binary);
  const std::string bytes_a((std::istreambuf_iterator<char>(a)), std::istreambuf_iterator<char>());
  const std::string bytes_b((std::istreambuf_iterator<char>(b)), std::istreambuf_iterator<char>());
  EXPECT_EQ(bytes_a, bytes_b);
}

TEST(CliSegment, BoneFromThePhantomCtMatchesItsVertebrae) {
  const auto phantom = coarsePhantom("phantom");
  const auto out = scratchDirectory("bone");
  const auto j = parse(runCli({"segment", (phantom / "phantom_ct.nrrd").string(), "--output", out.string(), "--json"}));
  EXPECT_EQ(j["mode"], "bone");
  EXPECT_TRUE(std::filesystem::is_regular_file(out / "bone_labels.nrrd"));
  EXPECT_TRUE(std::filesystem::is_regular_file(out / "bone.stl"));
  ASSERT_EQ(j["meshes"].size(), 1U);
  EXPECT_EQ(j["meshes"][0]["name"], "bone");
  EXPECT_TRUE(j["meshes"][0]["closed"].get<bool>());
  // The bone volume is that of the five vertebrae and the screws of the label
  // map, within the discretisation bound of both surfaces.
  const auto labels = parse(runCli(
      {"segment", (phantom / "phantom_labels.nrrd").string(), "--output", scratchDirectory("l").string(), "--json"}));
  double truth_ml = 0.0, tolerance_ml = j["meshes"][0]["volume_tolerance_ml"].get<double>();
  for (const auto& m : labels["meshes"]) {
    if (m["name"] == "carotid_artery") continue;
    truth_ml += m["voxel_volume_ml"].get<double>();
  }
  EXPECT_NEAR(j["bone"]["volume_ml"].get<double>(), truth_ml, tolerance_ml);
  EXPECT_GE(j["bone"]["components_kept"].get<int>(), 1);
}

TEST(CliSegment, PhantomLabelMapGivesNamedMeshes) {
  const auto phantom = coarsePhantom("phantom");
  const auto out = scratchDirectory("meshes");
  const auto j = parse(runCli({"segment", (phantom / "phantom_labels.nrrd").string(), "--output", out.string(),
                               "--target-triangles", "2000", "--smoothing", "10", "--format", "vtp", "--json"}));
  EXPECT_EQ(j["mode"], "labels");
  EXPECT_EQ(j["label_scheme"], "verse");
  std::vector<std::string> names;
  for (const auto& m : j["meshes"]) {
    names.push_back(m["name"]);
    EXPECT_LE(m["triangles"].get<int>(), 2200);
    EXPECT_TRUE(std::filesystem::is_regular_file(m["file"].get<std::string>()));
  }
  EXPECT_EQ(names, (std::vector<std::string>{"C3", "C4", "C5", "C6", "C7", "carotid_artery", "fiducial_screws"}));
  EXPECT_TRUE(std::filesystem::is_regular_file(out / "C5.vtp"));
}

TEST(CliSegment, RealTotalSegmentatorLabelsAreNamed) {
  MRSNS_REQUIRE_DATA(labels, "ct/totalsegmentator/spine_report/example_ct_report/totalseg.nii.gz");
  const auto out = scratchDirectory("totalseg");
  const auto j = parse(runCli({"segment", labels.string(), "--output", out.string(), "--json"}));
  EXPECT_EQ(j["label_scheme"], "totalsegmentator");
  ASSERT_EQ(j["meshes"].size(), 8U);
  EXPECT_EQ(j["meshes"][0]["name"], "vertebrae_S1");
  EXPECT_EQ(j["meshes"][5]["name"], "vertebrae_L1");
  EXPECT_TRUE(std::filesystem::is_regular_file(out / "vertebrae_L1.stl"));
}

TEST(CliSegment, RefusesImagesWithoutBoneAndBadArguments) {
  const auto phantom = coarsePhantom("phantom");
  const auto out = scratchDirectory("bad");
  const auto no_bone =
      runCli({"segment", (phantom / "phantom_ct.nrrd").string(), "--output", out.string(), "--threshold", "4000"});
  EXPECT_EQ(no_bone.exit_code, 1);
  EXPECT_NE(no_bone.err.find("no voxel above 4000 HU: is this a CT?"), std::string::npos) << no_bone.err;
  const auto missing = runCli({"segment", (out / "nothing.nrrd").string(), "--output", out.string()});
  EXPECT_EQ(missing.exit_code, 1);
  EXPECT_NE(missing.err.find("nothing.nrrd"), std::string::npos) << missing.err;
  EXPECT_EQ(runCli({"segment", (phantom / "phantom_ct.nrrd").string()}).exit_code, 2) << "--output is required";
  EXPECT_EQ(runCli({"make-phantom", "--output", out.string(), "--spacing", "0"}).exit_code, 2);
}

}  // namespace
}  // namespace mrsns::test
