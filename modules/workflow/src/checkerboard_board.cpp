#include "checkerboard_board.h"

#include <fstream>

#include "mrsns/core/rigid.h"

namespace mrsns::workflow::detail {

std::vector<Eigen::Vector3d> BoardDefinition::cornersMarker() const {
  std::vector<Eigen::Vector3d> out;
  for (const auto& c : hmd::idealGridCorners(spec)) out.push_back(marker_T_grid * c);
  return out;
}

BoardDefinition readBoardDefinition(const std::filesystem::path& file) {
  std::ifstream in(file);
  if (!in) throw FileError("cannot read the checkerboard board definition '" + file.string() + "'");
  Json j;
  try {
    j = Json::parse(in);
  } catch (const Json::parse_error& e) {
    throw FormatError("'" + file.string() + "' is not valid JSON (" + e.what() + ")");
  }
  const std::string where = "'" + file.string() + "'";
  if (!j.is_object() || j.value("format", "") != "mrsns-checkerboard-board/1") {
    throw FormatError(where + ": not a checkerboard board definition (\"format\": \"mrsns-checkerboard-board/1\")");
  }
  BoardDefinition b;
  b.file = file.string();
  b.name = j.contains("name") && j["name"].is_string() ? j["name"].get<std::string>() : file.stem().string();
  if (!j.contains("rows") || !j["rows"].is_number_integer() || !j.contains("cols") ||
      !j["cols"].is_number_integer() || !j.contains("square_mm") || !j["square_mm"].is_number()) {
    throw FormatError(where + ": needs rows and cols (inner corners, integers) and square_mm");
  }
  b.spec = {j["rows"].get<int>(), j["cols"].get<int>(), j["square_mm"].get<double>()};
  if (b.spec.rows < 2 || b.spec.cols < 2 || b.spec.rows > 30 || b.spec.cols > 30 || !(b.spec.square_mm >= 2.0) ||
      !(b.spec.square_mm <= 500.0)) {
    throw FormatError(where + ": rows and cols must be 2-30 inner corners and square_mm 2-500");
  }
  if (j.contains("grid_to_marker")) {
    b.marker_T_grid.matrix() = matrixFromJson(j["grid_to_marker"], where + " grid_to_marker");
    if (!isRigid(b.marker_T_grid.matrix(), 1e-6)) throw FormatError(where + ": grid_to_marker is not rigid");
  }
  return b;
}

BoardDefinition boardOfStep(const Params& p) {
  return readBoardDefinition(p.has("board") ? std::filesystem::path(p.text("board", ""))
                                            : resourceDirectory() / "devices" / "checkerboard_board.json");
}

std::optional<std::filesystem::path> digitisedCorners(const Session& session, const std::string& board_tool,
                                                      const hmd::CheckerboardSpec& spec) {
  const auto entry = session.step("checkerboard-digitisation");
  if (entry.is_null() || entry.value("status", "") != "ok" || !entry.contains("figures")) return std::nullopt;
  const auto& f = entry["figures"];
  // A session file edited by hand: anything not as this step wrote it is not a digitisation to use.
  if (!f.is_object() || !f.contains("board_tool") || !f["board_tool"].is_string() ||
      f["board_tool"].get<std::string>() != board_tool || !f.contains("board") || !f["board"].is_object() ||
      !f.contains("corners_file") || !f["corners_file"].is_string()) {
    return std::nullopt;
  }
  const auto& b = f["board"];
  const auto number = [&](const char* key) {
    return b.contains(key) && b[key].is_number() ? b[key].get<double>() : -1.0;
  };
  if (number("rows") != spec.rows || number("cols") != spec.cols || std::abs(number("square_mm") - spec.square_mm) > 1e-9) {
    return std::nullopt;
  }
  const auto path = session.resolve(f["corners_file"].get<std::string>());
  if (!std::filesystem::exists(path)) return std::nullopt;
  return path;
}

}  // namespace mrsns::workflow::detail
