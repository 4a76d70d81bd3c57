#pragma once
// The GUI's work on session data that is not a workflow step: importing a
// file (read with io to check it, then copied into the session folder),
// pivot calibration from a pose file, and filling the scene and slice views
// with what the session holds. Runs on the worker (imports, pivot) or the GUI
// thread (scene); throws mrsns::Error subclasses with actionable messages.
#include <QString>
#include <filesystem>
#include <map>
#include <string>

#include "function_panel.h"
#include "mrsns/core/mesh.h"
#include "preparation_panel.h"
#include "task_runner.h"

namespace mrsns::workflow {
class Session;
}
namespace mrsns::rendering {
class Scene;
class SliceViews;
}  // namespace mrsns::rendering

namespace mrsns::gui {

/// The file dialog filter of each import kind.
QString importFileFilter(ImportKind kind);
/// The session's record name of an import kind ("import-ct", "import-mesh", ...).
std::string importRecordName(ImportKind kind);

/// Reads `file` (so a broken file is refused before it enters the session),
/// copies it to <session_folder>/imported/ and returns its figures; the
/// outcome's outputs hold the copy's path relative to the session folder.
TaskOutcome importIntoSession(ImportKind kind, const std::filesystem::path& file,
                              const std::filesystem::path& session_folder, const TaskControl& control);

/// Shows every mesh, CT volume and planned path the session refers to (any
/// string in its state naming an existing file of a known kind). Scene
/// object names carry their layer as a prefix ("vertebra:", "tissue:",
/// "path:", "tool:", "us:"). Returns the meshes shown, by scene name.
std::map<std::string, TriangleMesh> loadSessionScene(const workflow::Session& session, rendering::Scene& scene,
                                                     rendering::SliceViews& slices);

/// Shows or hides every scene object of a layer.
void applyLayerVisibility(rendering::Scene& scene, DisplayLayer layer, bool visible);

}  // namespace mrsns::gui
