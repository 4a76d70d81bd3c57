// `mrsns-cli hmd-checkerboard-trial` (simulated 10-pose protocol of paper 000)
// and `mrsns-cli hmd-calibrate-checkerboard` (the same pipeline on recorded
// data). Data set layout read by the latter (and written by the trial with
// --write-dataset), documented in modules/hmd/doc/checkerboard.md:
//   images/*.png          HMD camera images, processed in file-name order
//   hmd_poses.csv         HmdToTracker per image (io/pose_csv.h: 16 or 17 columns)
//   board_poses.csv       BoardToTracker per image
//   corners.csv           digitised inner corners in the board-marker frame, mm,
//                         "x,y,z" per line, row-major (row 0 col 0, row 0 col 1, ...)
//   intrinsics.json       optional: the camera's intrinsics
//   calibration/*.png     optional: images of a printed board for the intrinsics
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "cli_context.h"
#include "mrsns/core/error.h"
#include "mrsns/core/rigid.h"
#include "mrsns/hmd/checkerboard_dataset.h"
#include "mrsns/hmd/checkerboard_trial.h"
#include "mrsns/io/file_names.h"
#include "mrsns/io/pose_csv.h"
#include "mrsns/io/transform_io.h"

namespace mrsns::cli {
namespace {

namespace fs = std::filesystem;
constexpr double kRadToDeg = 180.0 / 3.14159265358979323846;

Json poseJson(const Eigen::Isometry3d& T) {
  Json j;
  j["matrix_row_major"] = toRowMajor(T);
  j["translation_mm"] = {T.translation().x(), T.translation().y(), T.translation().z()};
  j["rotation_angle_deg"] = rotationAngle(T.linear()) * kRadToDeg;
  return j;
}

// Tables 1-2 of paper 000.
Json dispersionJson(const TransformDispersion& d) {
  Json axes = Json::object();
  const char* names[] = {"x", "y", "z"};
  for (size_t k = 0; k < 3; ++k) {
    const auto& a = d.axes[k];
    axes[names[k]] = {{"mean_direction", {a.mean_direction.x(), a.mean_direction.y(), a.mean_direction.z()}},
                      {"circular_variance", a.circular_variance},
                      {"circular_std_rad", a.circular_std},
                      {"deviation_mean_deg", a.deviation_mean_deg},
                      {"deviation_std_deg", a.deviation_std_deg}};
  }
  return {{"count", d.count},
          {"axes", axes},
          {"offset_mean_mm", {d.offset_mean.x(), d.offset_mean.y(), d.offset_mean.z()}},
          {"offset_std_mm", {d.offset_std.x(), d.offset_std.y(), d.offset_std.z()}}};
}

Json rpeeJson(const hmd::RetroProjectionResult& r) {
  return {{"mm", {{"mean", r.mean_mm}, {"std", r.std_mm}, {"rms", r.rms_mm}}},
          {"px", {{"mean", r.mean_px}, {"std", r.std_px}, {"rms", r.rms_px}}},
          {"corners", r.corner_error_mm.size()},
          {"per_image_rms_mm", r.per_view_rms_mm},
          {"per_image_rms_px", r.per_view_rms_px}};
}

Json intrinsicsJson(const hmd::CameraCalibrationResult& c) {
  const auto& k = c.intrinsics;
  return {{"fx", k.fx},
          {"fy", k.fy},
          {"cx", k.cx},
          {"cy", k.cy},
          {"distortion", k.distortion},
          {"width", k.width},
          {"height", k.height},
          {"images", c.images_used},
          {"rms_reprojection_px", c.rms_reprojection_px}};
}

Json gridJson(const hmd::GridFitResult& g) {
  return {{"board_T_grid", poseJson(g.board_T_grid)},
          {"rms_mm", g.rms_mm},
          {"inliers", g.inlier_count},
          {"residuals_mm", g.residuals_mm},
          {"line_rms_mm", g.line_rms_mm},
          {"row_column_angle_deg", g.row_column_angle_deg},
          {"mean_spacing_mm", g.mean_spacing_mm}};
}

std::string summaryText(const hmd::CheckerboardHandEyeResult& he, const hmd::RetroProjectionResult& rpee) {
  std::ostringstream t;
  const auto& x = he.hmd_T_camera.translation();
  t << "  T_c^h (CameraToHmd) translation: " << x.x() << ", " << x.y() << ", " << x.z() << " mm\n"
    << "  spread of per-image estimates: " << he.rotation_rms_rad * kRadToDeg << " deg RMS, " << he.translation_rms_mm
    << " mm RMS\n"
    << "  circular variance x/y/z: " << he.dispersion.axes[0].circular_variance << " / "
    << he.dispersion.axes[1].circular_variance << " / " << he.dispersion.axes[2].circular_variance << '\n'
    << "  RPEE: " << rpee.mean_mm << " +- " << rpee.std_mm << " mm, " << rpee.mean_px << " +- " << rpee.std_px
    << " px over " << rpee.corner_error_mm.size() << " corners\n";
  return t.str();
}

// ---- hmd-checkerboard-trial ---------------------------------------------------------------

struct TrialOptions {
  int poses = 10;
  unsigned seed = 1;
  int samples_per_image = 30;
  int intrinsics_images = 10;
  std::string write_dataset;
};

std::string imageName(const char* prefix, size_t i) {
  std::string n = std::to_string(i + 1);
  return std::string(prefix) + std::string(n.size() < 3 ? 3 - n.size() : 0, '0') + n + ".png";
}

Report runTrial(const TrialOptions& o) {
  hmd::CheckerboardTrialOptions t;
  t.poses = o.poses;
  t.seed = o.seed;
  t.tracker_samples_per_image = o.samples_per_image;
  t.intrinsics_images = o.intrinsics_images;
  t.keep_inputs = !o.write_dataset.empty();
  const auto r = hmd::runCheckerboardTrial(t);
  Report report;
  auto& j = report.json;
  j["verb"] = "hmd-checkerboard-trial";
  j["poses"] = o.poses;
  j["seed"] = o.seed;
  j["distances_mm"] = r.distances_mm;
  j["noise_model"] = {{"tracker_position_rms_mm_per_sample", t.tracker_position_rms_mm},
                      {"tracker_rotation_rms_deg_per_sample", t.tracker_rotation_rms_deg},
                      {"tracker_samples_averaged_per_image", t.tracker_samples_per_image},
                      {"digitisation_rms_mm", t.digitisation_rms_mm},
                      {"image_blur_sigma_px", t.render.blur_sigma_px},
                      {"image_noise_grey_levels", t.render.noise_sigma},
                      {"image_contrast_grey_levels", int(t.render.light) - int(t.render.dark)},
                      {"board", {{"rows", t.board.rows}, {"cols", t.board.cols}, {"square_mm", t.board.square_mm}}}};
  j["camera"] = intrinsicsJson(r.camera);
  j["pointer"] = {{"pivot_rms_mm", r.pointer_pivot_rms_mm}, {"tip_error_mm", r.pointer_tip_error_mm}};
  j["grid"] = gridJson(r.grid);
  j["grid"]["max_corner_error_mm"] = r.grid_error_mm;
  j["hmd_T_camera"] = poseJson(r.hand_eye.hmd_T_camera);
  j["error_vs_truth"] = {{"rotation_deg", r.rotation_error_deg}, {"translation_mm", r.translation_error_mm}};
  j["table1"] = dispersionJson(r.hand_eye.dispersion);
  j["rpee"] = rpeeJson(r.rpee);
  j["paper_000"] = {{"rpee_mm", {{"mean", 3.2}, {"std", 1.6}}}, {"circular_variance_max", 4.18e-6}};
  j["goal_rpee_mm"] = 2.0;
  j["goal_met"] = r.rpee.mean_mm < 2.0;
  if (!o.write_dataset.empty()) {
    const fs::path dir(o.write_dataset);
    fs::create_directories(dir / "images");
    fs::create_directories(dir / "calibration");
    std::vector<Eigen::Isometry3d> hmd_poses, board_poses;
    for (size_t i = 0; i < r.views.size(); ++i) {
      hmd::writeGrayImage(dir / "images" / imageName("pose_", i), r.images[i]);
      hmd_poses.push_back(r.views[i].tracker_T_hmd);
      board_poses.push_back(r.views[i].tracker_T_board);
    }
    for (size_t i = 0; i < r.intrinsics_images.size(); ++i) {
      hmd::writeGrayImage(dir / "calibration" / imageName("calib_", i), r.intrinsics_images[i]);
    }
    io::writePoseCsv(dir / "hmd_poses.csv", hmd_poses);
    io::writePoseCsv(dir / "board_poses.csv", board_poses);
    hmd::writeBoardCorners(dir / "corners.csv", r.digitised_corners);
    std::ofstream truth(dir / "truth.json");
    truth << Json{{"hmd_T_camera", poseJson(r.true_hmd_T_camera)},
                  {"board", {{"rows", t.board.rows}, {"cols", t.board.cols}, {"square_mm", t.board.square_mm}}},
                  {"calibration_board",
                   {{"rows", t.intrinsics_board.rows},
                    {"cols", t.intrinsics_board.cols},
                    {"square_mm", t.intrinsics_board.square_mm}}}}
                 .dump(2);
    j["dataset"] = o.write_dataset;
  }
  std::ostringstream text;
  text << "Checkerboard hand-eye trial (paper 000 protocol): " << o.poses << " poses at " << r.distances_mm.front()
       << "-" << r.distances_mm.back() << " mm\n"
       << summaryText(r.hand_eye, r.rpee) << "  error vs truth: " << r.rotation_error_deg << " deg, "
       << r.translation_error_mm << " mm\n"
       << "  paper 000: RPEE 3.2 +- 1.6 mm; goal < 2 mm: " << (r.rpee.mean_mm < 2.0 ? "met" : "NOT met") << '\n';
  report.text = text.str();
  return report;
}

// ---- hmd-calibrate-checkerboard -----------------------------------------------------------

struct CalibrateOptions {
  std::string dataset, images, hmd_poses, board_poses, corners, calibration_images, intrinsics, output;
  int rows = 3, cols = 5;
  double square_mm = 40.0;
  int calib_rows = 6, calib_cols = 9;
  double calib_square_mm = 25.0;
};

Report runCalibrate(const CalibrateOptions& o) {
  const fs::path base(o.dataset);
  auto pick = [&](const std::string& given, const char* fallback) {
    return given.empty() ? base / fallback : fs::path(given);
  };
  if (o.dataset.empty() && (o.images.empty() || o.hmd_poses.empty() || o.board_poses.empty() || o.corners.empty())) {
    throw InvalidArgumentError("give --dataset DIR, or all of --images, --hmd-poses, --board-poses and --corners");
  }
  hmd::CheckerboardDatasetFiles files;
  if (!o.dataset.empty()) files = hmd::checkerboardDatasetIn(base);
  files.images = pick(o.images, "images");
  files.hmd_poses = pick(o.hmd_poses, "hmd_poses.csv");
  files.board_poses = pick(o.board_poses, "board_poses.csv");
  files.corners = pick(o.corners, "corners.csv");
  if (!o.intrinsics.empty()) {
    if (!fs::exists(o.intrinsics)) throw FileError("camera intrinsics '" + o.intrinsics + "' do not exist");
    files.intrinsics = o.intrinsics;
  }
  if (!o.calibration_images.empty()) {
    if (!fs::is_directory(o.calibration_images)) {
      throw FileError("image folder '" + o.calibration_images + "' does not exist");
    }
    files.calibration_images = o.calibration_images;
    if (o.intrinsics.empty()) files.intrinsics.clear();
  }
  hmd::CheckerboardDatasetOptions options;
  options.board = {o.rows, o.cols, o.square_mm};
  options.calibration_board = {o.calib_rows, o.calib_cols, o.calib_square_mm};
  const auto r = hmd::calibrateCheckerboardDataset(files, options);
  const auto& he = r.hand_eye;

  Report report;
  auto& j = report.json;
  j["verb"] = "hmd-calibrate-checkerboard";
  j["images"] = r.image_names.size();
  j["camera"] = intrinsicsJson(r.camera);
  j["camera"]["source"] = r.intrinsics_source;
  j["grid"] = gridJson(r.grid);
  j["hmd_T_camera"] = poseJson(he.hmd_T_camera);
  j["per_image_pnp_rms_px"] = he.per_view_pnp_rms_px;
  j["spread"] = {{"rotation_rms_deg", he.rotation_rms_rad * kRadToDeg}, {"translation_rms_mm", he.translation_rms_mm}};
  j["table1"] = dispersionJson(he.dispersion);
  j["rpee"] = rpeeJson(r.rpee);
  if (!o.output.empty()) {
    // The node CameraToHmd (io/transform_io.h: an ITK file holds the inverse of its ToParent, a .txt hmd_T_camera).
    io::writeChildToParent(he.hmd_T_camera.matrix(), o.output);
    j["output"] = o.output;
  }
  report.text = "Checkerboard hand-eye calibration from " + std::to_string(r.image_names.size()) + " images (" +
                "intrinsics from " + r.intrinsics_source + ")\n" + summaryText(he, r.rpee);
  return report;
}

}  // namespace

void registerHmdCheckerboardVerbs(CLI::App& app, GlobalOptions& options, VerbList& verbs) {
  auto trial = std::make_shared<TrialOptions>();
  auto* t = app.add_subcommand("hmd-checkerboard-trial",
                               "simulated checkerboard hand-eye protocol of paper 000: rendered HMD camera images at "
                               "0.5-1.5 m, RPEE (px, mm) and the directional statistics of Table 1");
  t->add_option("--poses", trial->poses, "camera poses (images)")->capture_default_str()->check(CLI::Range(3, 200));
  t->add_option("--seed", trial->seed, "random seed")->capture_default_str();
  t->add_option("--samples-per-image", trial->samples_per_image,
                "tracker samples averaged per still image (1 = a single sample, as a naive protocol)")
      ->capture_default_str()
      ->check(CLI::Range(1, 1000));
  t->add_option("--intrinsics-images", trial->intrinsics_images, "images of the printed board for the intrinsics")
      ->capture_default_str()
      ->check(CLI::Range(4, 100));
  t->add_option("--write-dataset", trial->write_dataset,
                "also write the rendered images, tracked poses and digitised corners as a data set for "
                "hmd-calibrate-checkerboard");
  addJsonFlag(*t, options);
  verbs.emplace_back(t, [trial] { return runTrial(*trial); });

  auto cal = std::make_shared<CalibrateOptions>();
  auto* c = app.add_subcommand("hmd-calibrate-checkerboard",
                               "checkerboard hand-eye calibration of the HMD camera (paper 000) from images, tracked "
                               "HMD/board poses and digitised corners: T_c^h, Table 1 statistics and RPEE");
  c->add_option("--dataset", cal->dataset,
                "folder with images/, hmd_poses.csv, board_poses.csv, corners.csv [, calibration/]");
  c->add_option("--images", cal->images, "folder of HMD camera images (file-name order)");
  c->add_option("--hmd-poses", cal->hmd_poses, "HmdToTracker pose CSV, one line per image");
  c->add_option("--board-poses", cal->board_poses, "BoardToTracker pose CSV, one line per image");
  c->add_option("--corners", cal->corners, "digitised corners x,y,z (board-marker frame, mm), row-major");
  c->add_option("--calibration-images", cal->calibration_images, "folder of printed-board images for the intrinsics");
  c->add_option("--intrinsics", cal->intrinsics,
                "the camera's intrinsics (mrsns-camera-intrinsics/1 JSON); default: intrinsics.json in the data set, "
                "else from the calibration images, else estimated from the hand-eye images");
  c->add_option("--rows", cal->rows, "inner corner rows of the tracked board")->capture_default_str();
  c->add_option("--cols", cal->cols, "inner corner columns of the tracked board")->capture_default_str();
  c->add_option("--square", cal->square_mm, "square size of the tracked board, mm")->capture_default_str();
  c->add_option("--calib-rows", cal->calib_rows, "inner corner rows of the printed board")->capture_default_str();
  c->add_option("--calib-cols", cal->calib_cols, "inner corner columns of the printed board")->capture_default_str();
  c->add_option("--calib-square", cal->calib_square_mm, "square size of the printed board, mm")->capture_default_str();
  c->add_option("--output", cal->output,
                "write the transform CameraToHmd (camera -> HMD marker): .tfm/.h5/.mat as 3D Slicer reads them (the "
                "inverse, LPS), .txt the plain 4x4 hmd_T_camera");
  addJsonFlag(*c, options);
  verbs.emplace_back(c, [cal] { return runCalibrate(*cal); });
}

}  // namespace mrsns::cli
