// deform-track through the real binary, on a simulated case written by
// `deform-trial --write-case` (the vessel phantom: model, truth, 8-bit B-mode
// sweep with calibration and tracking error, ideal external contours).
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <iomanip>
#include <nlohmann/json.hpp>

#include "cli_runner.h"
#include "mrsns/core/surface_distance.h"
#include "mrsns/io/mesh_io.h"
#include "test_data.h"

namespace mrsns::test {
namespace {

constexpr int kFrames = 30;

// One simulated case in `dir` (writing it takes ~1 s).
std::filesystem::path writeCase(const std::filesystem::path& dir) {
  const auto d = dir / "case";
  const auto r = runCli(
      {"deform-trial", "--write-case", d.string(), "--frames", std::to_string(kFrames), "--seed", "4", "--json"});
  EXPECT_EQ(r.exit_code, 0) << r.err;
  return d;
}

// E^SD (Eq. 22): symmetric mean surface distance.
double meanSurfaceDistance(const TriangleMesh& a, const TriangleMesh& b) {
  return surfaceDistance(a, b).mean;
}

struct Track {
  nlohmann::json json;
  double posterior_error_mm = 0.0;
  double prior_error_mm = 0.0;
};

Track track(const std::filesystem::path& c, const std::string& name, std::vector<std::string> extra) {
  const auto out = c.parent_path() / name;
  std::vector<std::string> args{"deform-track",
                                "--model",
                                (c / "model.h5").string(),
                                "--sequence",
                                (c / "sweep.igs.mha").string(),
                                "--calibration",
                                (c / "ImageToProbe.txt").string(),
                                "--out",
                                out.string(),
                                "--every",
                                "10",
                                "--json"};
  args.insert(args.end(), extra.begin(), extra.end());
  const auto r = runCli(args);
  EXPECT_EQ(r.exit_code, 0) << r.err;
  Track t;
  if (r.exit_code != 0) return t;
  t.json = nlohmann::json::parse(r.out);
  const TriangleMesh truth = io::readMesh(c / "truth.vtp");
  const auto mean = runCli({"ssm", "convert", (c / "model.h5").string(), (out / "mean.vtp").string()});
  EXPECT_EQ(mean.exit_code, 0) << mean.err;
  t.prior_error_mm = meanSurfaceDistance(io::readMesh(out / "mean.vtp"), truth);
  t.posterior_error_mm = meanSurfaceDistance(io::readMesh(t.json["meshes"].back()["file"].get<std::string>()), truth);
  return t;
}

TEST(CliDeformTrack, BuiltInSegmenterGivesPosteriorMeshesAndSummary) {
  const auto c = writeCase(scratchDirectory("cli_deform_track"));
  const Track t = track(c, "bmode", {});
  const auto& j = t.json;
  ASSERT_FALSE(j.is_null());
  for (const char* key : {"frames", "frames_used", "frames_refused", "refusals", "contours_segmented", "mahalanobis",
                          "plausible", "observations", "update_ms", "meshes"}) {
    EXPECT_TRUE(j.contains(key)) << key;
  }
  EXPECT_EQ(j["frames"], kFrames);
  EXPECT_EQ(j["contour_source"], "bmode-segmenter");
  EXPECT_GT(j["frames_used"].get<int>(), kFrames / 2);
  EXPECT_EQ(j["frames_used"].get<int>() + j["frames_refused"].get<int>(), kFrames);
  EXPECT_TRUE(j["update_ms"].contains("p50"));
  EXPECT_TRUE(j["update_ms"].contains("p99"));
  // Every 10 frames: after frames 9, 19, 29 (the last).
  ASSERT_EQ(j["meshes"].size(), 3u);
  for (const auto& m : j["meshes"]) EXPECT_TRUE(std::filesystem::exists(m["file"].get<std::string>()));
  EXPECT_EQ(j["meshes"].back()["frame"], kFrames - 1);
  // The posterior is closer to the held-out truth than the prior mean.
  EXPECT_LT(t.posterior_error_mm, t.prior_error_mm)
      << "posterior " << t.posterior_error_mm << " prior " << t.prior_error_mm;
}

TEST(CliDeformTrack, ExternalContoursFromJsonAndCsvFiles) {
  const auto c = writeCase(scratchDirectory("cli_deform_track"));
  const Track tj = track(c, "json", {"--contours", (c / "contours.json").string(), "--format", "stl"});
  ASSERT_FALSE(tj.json.is_null());
  EXPECT_EQ(tj.json["frames_with_external_contours"], kFrames);
  EXPECT_EQ(tj.json["contours_segmented"], 0);
  EXPECT_NE(tj.json["meshes"][0]["file"].get<std::string>().find(".stl"), std::string::npos);
  EXPECT_LT(tj.posterior_error_mm, tj.prior_error_mm);
  // The same contours as CSV (frame,contour,x,y).
  std::ifstream in(c / "contours.json");
  const auto contours = nlohmann::json::parse(in);
  const auto csv = c.parent_path() / "contours.csv";
  {
    std::ofstream out(csv);
    out << std::setprecision(17);
    out << "frame,contour,x_mm,y_mm\n";
    for (const auto& f : contours["frames"]) {
      for (std::size_t k = 0; k < f["contours"].size(); ++k) {
        for (const auto& p : f["contours"][k])
          out << f["frame"].get<int>() << "," << k << "," << p[0].get<double>() << "," << p[1].get<double>() << "\n";
      }
    }
  }
  const Track tc = track(c, "csv", {"--contours", csv.string()});
  ASSERT_FALSE(tc.json.is_null());
  EXPECT_EQ(tc.json["frames_with_external_contours"], kFrames);
  EXPECT_NEAR(tc.posterior_error_mm, tj.posterior_error_mm, 1e-3);
}

TEST(CliDeformTrack, BadInputExitsOneWithOneLine) {
  const auto dir = scratchDirectory("cli_deform_track");
  const auto c = writeCase(dir);
  const auto garbage = dir / "garbage.h5";
  std::ofstream(garbage) << "not an HDF5 file";
  const auto out = (dir / "bad").string();
  const std::string model = (c / "model.h5").string(), seq = (c / "sweep.igs.mha").string(),
                    cal = (c / "ImageToProbe.txt").string();
  const std::vector<std::vector<std::string>> cases{
      {"--model", garbage.string(), "--sequence", seq, "--calibration", cal},
      {"--model", model, "--sequence", garbage.string(), "--calibration", cal},
      {"--model", model, "--sequence", seq},
      {"--model", model, "--sequence", seq, "--calibration", cal, "--contours", garbage.string()},
  };
  for (const auto& a : cases) {
    std::vector<std::string> args{"deform-track", "--out", out};
    args.insert(args.end(), a.begin(), a.end());
    const auto r = runCli(args);
    EXPECT_EQ(r.exit_code, 1) << a[1] << " " << a[3] << ": " << r.err;
    EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
  }
  EXPECT_EQ(runCli({"deform-track", "--model", model}).exit_code, 2);
}

}  // namespace
}  // namespace mrsns::test
