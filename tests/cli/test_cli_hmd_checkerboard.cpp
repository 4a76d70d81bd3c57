// `mrsns-cli hmd-checkerboard-trial` and `hmd-calibrate-checkerboard`: the
// trial writes a rendered data set (images, tracked poses, digitised
// corners), the calibration verb reads it back like recorded data.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "cli_runner.h"
#include "test_data.h"

namespace mrsns::test {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

// A uniform grey 24-bit BMP (no checkerboard in it).
void writeBlankBmp(const fs::path& path, int width, int height) {
  const int row = (3 * width + 3) / 4 * 4;
  const std::uint32_t size = 54 + static_cast<std::uint32_t>(row * height);
  auto u32 = [](std::ofstream& o, std::uint32_t v) {
    for (int i = 0; i < 4; ++i) o.put(static_cast<char>((v >> (8 * i)) & 0xff));
  };
  std::ofstream o(path, std::ios::binary);
  o.put('B');
  o.put('M');
  u32(o, size);
  u32(o, 0);
  u32(o, 54);
  u32(o, 40);
  u32(o, static_cast<std::uint32_t>(width));
  u32(o, static_cast<std::uint32_t>(height));
  o.put(1);
  o.put(0);
  o.put(24);
  o.put(0);
  for (int i = 0; i < 6; ++i) u32(o, 0);
  for (int i = 0; i < row * height; ++i) o.put(static_cast<char>(128));
}

json parse(const CliResult& r) {
  EXPECT_EQ(r.exit_code, 0) << r.err;
  return json::parse(r.out);
}

// One trial (4 poses, small) written as a data set, then calibrated from the files.
TEST(CliHmdCheckerboard, TrialWritesDatasetThatCalibrates) {
  const fs::path dir = scratchDirectory("checkerboard");
  const auto trial = parse(runCli({"hmd-checkerboard-trial", "--poses", "4", "--intrinsics-images", "6", "--seed", "5",
                                   "--write-dataset", (dir / "set").string(), "--json"}));
  EXPECT_EQ(trial["verb"], "hmd-checkerboard-trial");
  EXPECT_LT(trial["rpee"]["mm"]["mean"].get<double>(), 2.0);
  EXPECT_EQ(trial["rpee"]["corners"].get<int>(), 4 * 15);
  EXPECT_TRUE(trial["noise_model"].contains("tracker_rotation_rms_deg_per_sample"));
  EXPECT_TRUE(trial["table1"]["axes"]["z"].contains("circular_variance"));
  EXPECT_TRUE(trial["goal_met"].get<bool>());
  ASSERT_TRUE(fs::exists(dir / "set" / "images" / "pose_004.png"));
  ASSERT_TRUE(fs::exists(dir / "set" / "corners.csv"));

  const auto cal = parse(runCli({"hmd-calibrate-checkerboard", "--dataset", (dir / "set").string(), "--square", "40",
                                 "--output", (dir / "CameraToHmd.tfm").string(), "--json"}));
  EXPECT_EQ(cal["images"].get<int>(), 4);
  // Same images, poses and corners as the trial: the same pipeline gives the same figures.
  EXPECT_NEAR(cal["rpee"]["mm"]["mean"].get<double>(), trial["rpee"]["mm"]["mean"].get<double>(), 0.05);
  std::ifstream truth_file(dir / "set" / "truth.json");
  const json truth = json::parse(truth_file);
  const auto t_est = cal["hmd_T_camera"]["translation_mm"], t_true = truth["hmd_T_camera"]["translation_mm"];
  double d2 = 0;
  for (int i = 0; i < 3; ++i) d2 += std::pow(t_est[i].get<double>() - t_true[i].get<double>(), 2);
  EXPECT_LT(std::sqrt(d2), 9.0);  // the trial test's bound (grid rotation error x 1 m lever)
  EXPECT_TRUE(fs::exists(dir / "CameraToHmd.tfm"));
}

void writeIntrinsics(const fs::path& path, const json& j) { std::ofstream(path) << j.dump(2); }

json trialCamera() {
  // hmd::CheckerboardTrialOptions' camera: what the trial renders its images through.
  return {{"format", "mrsns-camera-intrinsics/1"}, {"fx", 1000.0}, {"fy", 1000.0}, {"cx", 640.0}, {"cy", 360.0},
          {"distortion", {-0.05, 0.02, 0.0, 0.0, 0.0}}, {"width", 1280}, {"height", 720}};
}

TEST(CliHmdCheckerboard, AnIntrinsicsFileIsUsedAsGivenAndTheSessionStepSolvesTheSameDataSet) {
  const fs::path dir = scratchDirectory("checkerboard_intrinsics");
  ASSERT_EQ(runCli({"hmd-checkerboard-trial", "--poses", "5", "--intrinsics-images", "4", "--seed", "7",
                    "--write-dataset", (dir / "set").string(), "--json"})
                .exit_code,
            0);
  writeIntrinsics(dir / "camera.json", trialCamera());
  const auto cal = parse(runCli({"hmd-calibrate-checkerboard", "--dataset", (dir / "set").string(), "--intrinsics",
                                 (dir / "camera.json").string(), "--json"}));
  EXPECT_EQ(cal["camera"]["source"], "file");
  EXPECT_EQ(cal["camera"]["fx"].get<double>(), 1000.0);
  EXPECT_EQ(cal["camera"]["cy"].get<double>(), 360.0);
  // The workflow step on the same data set (source=file): the same function, the same numbers, and the user's
  // folder left as it was.
  const auto listing = [&] {
    std::vector<std::string> names;
    for (const auto& e : fs::recursive_directory_iterator(dir / "set")) names.push_back(e.path().string());
    std::sort(names.begin(), names.end());
    return names;
  };
  const auto before = listing();
  const fs::path session = dir / "session";
  ASSERT_EQ(runCli({"session", "create", session.string()}).exit_code, 0);
  const auto step = runCli({"session", "run", session.string(), "hmd-camera-calibration", "--param", "source=file",
                            "--param", "dataset=" + (dir / "set").string(), "--param",
                            "intrinsics=" + (dir / "camera.json").string(), "--json"});
  ASSERT_EQ(step.exit_code, 0) << step.err;
  const auto figures = json::parse(step.out)["figures"];
  EXPECT_EQ(figures["camera"]["intrinsics_from"].get<std::string>().rfind("file", 0), 0U);
  EXPECT_EQ(figures["board"]["corners_from"], (dir / "set" / "corners.csv").string());
  for (std::size_t k = 0; k < 16; ++k) {
    EXPECT_NEAR(figures["transforms"]["CameraToHeadset"][k].get<double>(),
                cal["hmd_T_camera"]["matrix_row_major"][k].get<double>(), 1e-12);
  }
  EXPECT_EQ(listing(), before);
  // Without an intrinsics file the data set's printed-board images give them, as in the verb.
  const auto by_images = runCli({"session", "run", session.string(), "hmd-camera-calibration", "--param",
                                 "source=file", "--param", "dataset=" + (dir / "set").string(), "--json"});
  ASSERT_EQ(by_images.exit_code, 0) << by_images.err;
  EXPECT_EQ(json::parse(by_images.out)["figures"]["camera"]["intrinsics_from"], "calibration images");
  // Live parameters are refused for a file, a missing data set is named.
  auto r = runCli({"session", "run", session.string(), "hmd-camera-calibration", "--param", "source=file", "--param",
                   "dataset=" + (dir / "set").string(), "--param", "views=5"});
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find("views is for source=hmd"), std::string::npos) << r.err;
  r = runCli({"session", "run", session.string(), "hmd-camera-calibration", "--param", "source=file", "--param",
              "dataset=" + (dir / "nothing").string()});
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find("is not a folder"), std::string::npos) << r.err;
}

TEST(CliHmdCheckerboard, IntrinsicsACameraCannotHaveAreRefusedNamingWhatIsWrong) {
  const fs::path dir = scratchDirectory("checkerboard_bad_intrinsics");
  ASSERT_EQ(runCli({"hmd-checkerboard-trial", "--poses", "3", "--intrinsics-images", "4", "--seed", "8",
                    "--write-dataset", (dir / "set").string(), "--json"})
                .exit_code,
            0);
  const std::vector<std::pair<json, std::string>> cases = {
      {json{{"fx", -5.0}}, "focal lengths fx, fy must be positive"},
      {json{{"cx", 5000.0}}, "principal point"},
      {json{{"width", 640}}, "are for 640 x 720 pixels, the images are 1280 x 720"},
      {json{{"format", "opencv"}}, "mrsns-camera-intrinsics/1"},
      {json{{"distortion", {1, 2}}}, "distortion"},
  };
  for (const auto& [patch, message] : cases) {
    json j = trialCamera();
    j.update(patch);
    writeIntrinsics(dir / "k.json", j);
    const auto r = runCli({"hmd-calibrate-checkerboard", "--dataset", (dir / "set").string(), "--intrinsics",
                           (dir / "k.json").string(), "--json"});
    EXPECT_EQ(r.exit_code, 1) << patch.dump();
    EXPECT_NE(r.err.find(message), std::string::npos) << patch.dump() << ": " << r.err;
    EXPECT_TRUE(r.out.empty());
  }
  std::ofstream(dir / "k.json") << "{ not json";
  auto r = runCli({"hmd-calibrate-checkerboard", "--dataset", (dir / "set").string(), "--intrinsics",
                   (dir / "k.json").string()});
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find("not valid JSON"), std::string::npos) << r.err;
  r = runCli({"hmd-calibrate-checkerboard", "--dataset", (dir / "set").string(), "--intrinsics",
              (dir / "missing.json").string()});
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find("do not exist"), std::string::npos) << r.err;
}

TEST(CliHmdCheckerboard, BadInputGivesOneLineErrors) {
  const fs::path dir = scratchDirectory("checkerboard_bad");
  ASSERT_EQ(runCli({"hmd-checkerboard-trial", "--poses", "3", "--intrinsics-images", "4", "--seed", "6",
                    "--write-dataset", (dir / "set").string(), "--json"})
                .exit_code,
            0);
  // A checkerboard not found: the message names the image.
  fs::copy(dir / "set", dir / "blank", fs::copy_options::recursive);
  fs::remove(dir / "blank" / "images" / "pose_002.png");
  writeBlankBmp(dir / "blank" / "images" / "pose_002.bmp", 1280, 720);
  auto r = runCli({"hmd-calibrate-checkerboard", "--dataset", (dir / "blank").string(), "--json"});
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find("pose_002.bmp"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("not found"), std::string::npos) << r.err;
  EXPECT_TRUE(r.out.empty());
  // Pose count differs from the image count.
  fs::copy(dir / "set", dir / "short", fs::copy_options::recursive);
  {
    // All pose lines but the last (the file may start with a header line).
    std::ifstream in(dir / "set" / "hmd_poses.csv");
    std::vector<std::string> lines;
    for (std::string line; std::getline(in, line);) lines.push_back(line);
    std::ofstream out(dir / "short" / "hmd_poses.csv");
    for (size_t i = 0; i + 1 < lines.size(); ++i) out << lines[i] << '\n';
  }
  r = runCli({"hmd-calibrate-checkerboard", "--dataset", (dir / "short").string()});
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find("one line per image"), std::string::npos) << r.err;
  // Too few images.
  fs::copy(dir / "set", dir / "few", fs::copy_options::recursive);
  fs::remove(dir / "few" / "images" / "pose_003.png");
  r = runCli({"hmd-calibrate-checkerboard", "--dataset", (dir / "few").string()});
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find("at least 3"), std::string::npos) << r.err;
  // Usage errors.
  EXPECT_EQ(runCli({"hmd-checkerboard-trial", "--poses", "1"}).exit_code, 2);
  EXPECT_EQ(runCli({"hmd-calibrate-checkerboard", "--json"}).exit_code, 1);
}

}  // namespace
}  // namespace mrsns::test
