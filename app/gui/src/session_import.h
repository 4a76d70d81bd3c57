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

#include "mrsns/workflow/session_document.h"

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

/// What the scene has read from the session folder, kept while the files do
/// not change, so a session reloaded after a small change (a planned screw)
/// does not read every mesh and the CT again.
class SceneFileCache {
 public:
  /// The mesh in `file`, read again only when the file changed.
  const TriangleMesh& mesh(const std::filesystem::path& file);
  /// True (and remembered) when the CT file is not the one shown last.
  bool volumeChanged(const std::filesystem::path& file);
  void forgetVolume();

 private:
  std::map<std::string, std::pair<std::filesystem::file_time_type, TriangleMesh>> meshes_;
  std::string volume_file_;
  std::filesystem::file_time_type volume_stamp_{};
};

/// The scene name of a model: its layer as a prefix ("vertebra:" for bone and
/// fiducial models, "tissue:" for soft tissue, vessels and nerves) and its id.
std::string sceneName(const workflow::ModelEntry& model);

/// The colour a planned screw is drawn in, from its figures: green in bone,
/// amber for a breach under 2 mm (Gertzbein-Robbins B), red beyond or when it
/// cuts a vessel or a nerve.
Eigen::Vector3d screwColor(const workflow::PlannedScrew& screw);

/// Shows what the session's document holds: the CT in the slice views, each
/// model with its colour, opacity and visibility, the planned screws
/// ("path:<name>", coloured by their figures) and the fiducials. Scene object
/// names carry their layer as a prefix ("vertebra:", "tissue:", "path:",
/// "tool:", "us:"). Returns the meshes for the headset (each model's light
/// copy when it has one), by scene name. Throws FormatError listing the files
/// that could not be shown (the rest is shown).
std::map<std::string, TriangleMesh> loadSessionScene(const workflow::Session& session, rendering::Scene& scene,
                                                     rendering::SliceViews& slices, SceneFileCache& cache);

/// Shows or hides every scene object of a layer.
void applyLayerVisibility(rendering::Scene& scene, DisplayLayer layer, bool visible);

}  // namespace mrsns::gui
