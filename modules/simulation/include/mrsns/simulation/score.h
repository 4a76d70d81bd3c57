#pragma once
// Scores a session's results against a simulated operating room's truth, from
// outside the workstation: what `mrsns-sim score SESSION TRUTH` prints.
#include <filesystem>
#include <string>

namespace mrsns::simulation {

/// Compares every result of `session_dir`/session.json that the truth file
/// knows the answer to (ImageToProbe: corner errors; the temporal
/// calibration's lag; CTToPatient: error at the fiducials; RobotBaseToTracker:
/// error at the patient; the navigation's live soft tissue: E^SD and E^FP of
/// its posterior against the room's vessel at each frame's instant) and returns one JSON object (text) with a figure per
/// result and the list of results it could not score. The pivot calibration's
/// tip is scored against the tool's tip_mm. Throws FileError or
/// FormatError for an unreadable session or truth file.
[[nodiscard]] std::string scoreSession(const std::filesystem::path& session_dir,
                                       const std::filesystem::path& truth_file);

}  // namespace mrsns::simulation
