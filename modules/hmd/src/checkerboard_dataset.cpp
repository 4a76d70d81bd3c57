#include "mrsns/hmd/checkerboard_dataset.h"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>

#include "mrsns/core/error.h"
#include "mrsns/io/file_names.h"
#include "mrsns/io/pose_csv.h"

namespace mrsns::hmd {
namespace {

namespace fs = std::filesystem;
using Json = nlohmann::json;

// What a camera cannot have: refused with `where` named.
void checkIntrinsics(const CameraIntrinsics& k, const std::string& where) {
  const bool finite = std::isfinite(k.fx) && std::isfinite(k.fy) && std::isfinite(k.cx) && std::isfinite(k.cy) &&
                      std::all_of(k.distortion.begin(), k.distortion.end(), [](double d) { return std::isfinite(d); });
  if (!finite || !(k.fx > 0.0) || !(k.fy > 0.0)) {
    throw FormatError(where + ": the focal lengths fx, fy must be positive and every value finite");
  }
  if (k.width < 16 || k.height < 16 || k.width > 16384 || k.height > 16384) {
    throw FormatError(where + ": width and height must be 16-16384 pixels");
  }
  if (k.cx < 0.0 || k.cy < 0.0 || k.cx > k.width || k.cy > k.height) {
    throw FormatError(where + ": the principal point (cx, cy) must lie inside the image");
  }
}

}  // namespace

CheckerboardDatasetFiles checkerboardDatasetIn(const fs::path& dir) {
  CheckerboardDatasetFiles f;
  f.images = dir / "images";
  f.hmd_poses = dir / "hmd_poses.csv";
  f.board_poses = dir / "board_poses.csv";
  f.corners = dir / "corners.csv";
  if (fs::exists(dir / "intrinsics.json")) f.intrinsics = dir / "intrinsics.json";
  if (fs::is_directory(dir / "calibration")) f.calibration_images = dir / "calibration";
  return f;
}

std::vector<fs::path> imagesInFolder(const fs::path& dir) {
  if (!fs::is_directory(dir)) throw FileError("image folder '" + dir.string() + "' does not exist");
  std::vector<fs::path> out;
  for (const auto& e : fs::directory_iterator(dir)) {
    const std::string ext = io::lowerExtension(e.path());
    if (e.is_regular_file() && (ext == ".png" || ext == ".jpg" || ext == ".jpeg" || ext == ".bmp")) {
      out.push_back(e.path());
    }
  }
  std::sort(out.begin(), out.end());
  return out;
}

std::vector<Eigen::Vector3d> readBoardCorners(const fs::path& path) {
  std::ifstream in(path);
  if (!in) throw FileError("cannot open the board's corners file '" + path.string() + "'");
  std::vector<Eigen::Vector3d> pts;
  std::string line;
  int number = 0;
  while (std::getline(in, line)) {
    ++number;
    const auto first = line.find_first_not_of(" \t\r");
    if (first == std::string::npos || line[first] == '#') continue;
    std::replace(line.begin(), line.end(), ',', ' ');
    std::replace(line.begin(), line.end(), ';', ' ');
    std::istringstream s(line);
    Eigen::Vector3d p;
    std::string extra;
    if (!(s >> p.x() >> p.y() >> p.z()) || (s >> extra) || !p.allFinite()) {
      if (number == 1 && pts.empty()) continue;  // a header line
      throw FormatError("'" + path.string() + "' line " + std::to_string(number) +
                        ": expected three numbers x,y,z (mm, board-marker frame)");
    }
    pts.push_back(p);
  }
  return pts;
}

void writeBoardCorners(const fs::path& path, const std::vector<Eigen::Vector3d>& points) {
  std::ofstream out(path);
  out.precision(17);
  out << "# the board's inner corners in its marker's frame (mm), row-major\n";
  for (const auto& p : points) out << p.x() << ',' << p.y() << ',' << p.z() << '\n';
  if (!out) throw FileError("cannot write '" + path.string() + "'");
}

CameraIntrinsics readCameraIntrinsics(const fs::path& path) {
  std::ifstream in(path);
  if (!in) throw FileError("cannot open the camera intrinsics '" + path.string() + "'");
  Json j;
  try {
    j = Json::parse(in);
  } catch (const Json::parse_error& e) {
    throw FormatError("'" + path.string() + "' is not valid JSON (" + e.what() + ")");
  }
  const std::string where = "'" + path.string() + "'";
  if (!j.is_object() || j.value("format", "") != "mrsns-camera-intrinsics/1") {
    throw FormatError(where + ": not a camera intrinsics file (\"format\": \"mrsns-camera-intrinsics/1\")");
  }
  CameraIntrinsics k;
  auto number = [&](const char* key) {
    if (!j.contains(key) || !j[key].is_number()) throw FormatError(where + ": \"" + key + "\" must be a number");
    return j[key].get<double>();
  };
  k.fx = number("fx");
  k.fy = number("fy");
  k.cx = number("cx");
  k.cy = number("cy");
  const double w = number("width"), h = number("height");
  if (w != std::floor(w) || h != std::floor(h) || w < 0 || h < 0 || w > 1e6 || h > 1e6) {
    throw FormatError(where + ": width and height must be whole numbers of pixels");
  }
  k.width = static_cast<int>(w);
  k.height = static_cast<int>(h);
  if (j.contains("distortion")) {
    const auto& d = j["distortion"];
    if (!d.is_array() || d.size() < 4 || d.size() > 5) {
      throw FormatError(where + ": \"distortion\" must be [k1, k2, p1, p2] or [k1, k2, p1, p2, k3]");
    }
    for (std::size_t i = 0; i < d.size(); ++i) {
      if (!d[i].is_number()) throw FormatError(where + ": \"distortion\" must hold numbers");
      k.distortion[i] = d[i].get<double>();
    }
  }
  checkIntrinsics(k, where);
  return k;
}

void writeCameraIntrinsics(const fs::path& path, const CameraIntrinsics& k) {
  const Json j{{"format", "mrsns-camera-intrinsics/1"}, {"fx", k.fx},
               {"fy", k.fy},                            {"cx", k.cx},
               {"cy", k.cy},                            {"distortion", k.distortion},
               {"width", k.width},                      {"height", k.height}};
  std::ofstream out(path);
  out << j.dump(2) << '\n';
  if (!out) throw FileError("cannot write '" + path.string() + "'");
}

std::string intrinsicsText(const CameraIntrinsics& k) {
  std::ostringstream s;
  s.precision(17);
  s << k.fx << ' ' << k.fy << ' ' << k.cx << ' ' << k.cy;
  for (const double d : k.distortion) s << ' ' << d;
  s << ' ' << k.width << ' ' << k.height;
  return s.str();
}

CameraIntrinsics intrinsicsFromText(const std::string& text) {
  if (text.size() > 1024) throw FormatError("camera intrinsics: over 1024 characters");
  std::istringstream s(text);
  CameraIntrinsics k;
  double w = 0, h = 0;
  std::string extra;
  if (!(s >> k.fx >> k.fy >> k.cx >> k.cy >> k.distortion[0] >> k.distortion[1] >> k.distortion[2] >>
        k.distortion[3] >> k.distortion[4] >> w >> h) ||
      (s >> extra) || w != std::floor(w) || h != std::floor(h) || w < 0 || h < 0 || w > 1e6 || h > 1e6) {
    throw FormatError("camera intrinsics: expected \"fx fy cx cy k1 k2 p1 p2 k3 width height\"");
  }
  k.width = static_cast<int>(w);
  k.height = static_cast<int>(h);
  checkIntrinsics(k, "camera intrinsics");
  return k;
}

CheckerboardDatasetResult calibrateCheckerboardDataset(const CheckerboardDatasetFiles& files,
                                                       const CheckerboardDatasetOptions& options) {
  const auto image_paths = imagesInFolder(files.images);
  const auto hmd_poses = io::readPoseCsv(files.hmd_poses).poses;
  const auto board_poses = io::readPoseCsv(files.board_poses).poses;
  if (image_paths.size() < 3) {
    throw InvalidArgumentError("only " + std::to_string(image_paths.size()) + " images in '" + files.images.string() +
                               "': the checkerboard hand-eye calibration needs at least 3 (paper 000 used 10, at "
                               "0.5-1.5 m)");
  }
  if (hmd_poses.size() != image_paths.size() || board_poses.size() != image_paths.size()) {
    throw InvalidArgumentError(std::to_string(image_paths.size()) + " images but " + std::to_string(hmd_poses.size()) +
                               " HMD poses and " + std::to_string(board_poses.size()) +
                               " board poses: give one line per image, in file-name order");
  }
  CheckerboardDatasetResult r;
  r.grid = fitCheckerboardGrid(readBoardCorners(files.corners), options.board);

  std::vector<CheckerboardView> views;
  int width = 0, height = 0;
  for (std::size_t i = 0; i < image_paths.size(); ++i) {
    CheckerboardView v;
    v.name = image_paths[i].filename().string();
    const auto image = readGrayImage(image_paths[i]);
    if (i > 0 && (image.width != width || image.height != height)) {
      throw InvalidArgumentError("'" + v.name + "' is " + std::to_string(image.width) + " x " +
                                 std::to_string(image.height) + " pixels, the first image " + std::to_string(width) +
                                 " x " + std::to_string(height) + ": every image must come from the same camera mode");
    }
    width = image.width;
    height = image.height;
    v.corners_px = detectCheckerboardOrThrow(image, options.board, v.name);
    v.tracker_T_hmd = hmd_poses[i];
    v.tracker_T_board = board_poses[i];
    r.image_names.push_back(v.name);
    views.push_back(std::move(v));
  }
  if (!files.intrinsics.empty() && fs::exists(files.intrinsics)) {
    r.camera.intrinsics = readCameraIntrinsics(files.intrinsics);
    if (r.camera.intrinsics.width != width || r.camera.intrinsics.height != height) {
      throw InvalidArgumentError("the intrinsics in '" + files.intrinsics.string() + "' are for " +
                                 std::to_string(r.camera.intrinsics.width) + " x " +
                                 std::to_string(r.camera.intrinsics.height) + " pixels, the images are " +
                                 std::to_string(width) + " x " + std::to_string(height));
    }
    r.intrinsics_source = "file";
  } else if (!files.calibration_images.empty() && fs::is_directory(files.calibration_images)) {
    std::vector<std::vector<Eigen::Vector2d>> corners;
    int w = 0, h = 0;
    for (const auto& p : imagesInFolder(files.calibration_images)) {
      const auto image = readGrayImage(p);
      w = image.width;
      h = image.height;
      corners.push_back(detectCheckerboardOrThrow(image, options.calibration_board, p.filename().string()));
    }
    r.camera = calibrateCamera(corners, options.calibration_board, w, h);
    r.intrinsics_source = "calibration images";
  } else {
    std::vector<std::vector<Eigen::Vector2d>> corners;
    for (const auto& v : views) corners.push_back(v.corners_px);
    r.camera = calibrateCamera(corners, options.board, width, height);
    r.intrinsics_source = "views";
  }
  r.hand_eye = calibrateCheckerboardHandEye(views, r.grid.board_T_grid, options.board, r.camera.intrinsics);
  r.rpee = retroProjectionError(views, r.hand_eye.hmd_T_camera, r.grid.board_T_grid, options.board,
                                r.camera.intrinsics, r.hand_eye.corners_reversed);
  return r;
}

}  // namespace mrsns::hmd
