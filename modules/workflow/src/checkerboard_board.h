#pragma once
// The tracked checkerboard of paper 000 (§2.3) as the workflow knows it: its
// definition file (the pattern and where it sits on the board's marker, from
// the board's CAD) and, once the corners have been digitised with the stylus
// in this session (checkerboard-digitisation), where they really are.
#include <Eigen/Geometry>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "mrsns/hmd/checkerboard_grid.h"
#include "step_internal.h"

namespace mrsns::workflow::detail {

/// {"format": "mrsns-checkerboard-board/1", "name", "rows", "cols" (inner corners), "square_mm",
/// "grid_to_marker" (16 numbers, row-major: the pattern's frame on the marker; identity when absent)}.
struct BoardDefinition {
  std::string name, file;
  hmd::CheckerboardSpec spec;
  Eigen::Isometry3d marker_T_grid = Eigen::Isometry3d::Identity();
  /// The inner corners in the marker's frame, row-major, as defined.
  [[nodiscard]] std::vector<Eigen::Vector3d> cornersMarker() const;
};

/// Throws FileError, FormatError naming the file and what is wrong.
BoardDefinition readBoardDefinition(const std::filesystem::path& file);

/// The step's `board` parameter, else resources/devices/checkerboard_board.json.
BoardDefinition boardOfStep(const Params& p);

/// The corners file of this session's checkerboard-digitisation, when it succeeded for `board_tool` with a
/// board of the same pattern.
std::optional<std::filesystem::path> digitisedCorners(const Session& session, const std::string& board_tool,
                                                      const hmd::CheckerboardSpec& spec);

}  // namespace mrsns::workflow::detail
