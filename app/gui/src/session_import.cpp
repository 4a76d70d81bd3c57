#include "session_import.h"

#include <algorithm>
#include <optional>
#include <set>

#include "mrsns/core/error.h"
#include "mrsns/core/log.h"
#include "mrsns/io/file_names.h"
#include "mrsns/io/image_io.h"
#include "mrsns/io/landmarks_io.h"
#include "mrsns/io/mesh_io.h"
#include "mrsns/io/screw_path_io.h"
#include "mrsns/io/sequence_file.h"
#include "mrsns/rendering/scene.h"
#include "mrsns/rendering/slice_views.h"
#include "mrsns/rendering/tool_models.h"
#include "mrsns/workflow/session.h"

namespace mrsns::gui {
namespace fs = std::filesystem;

namespace {

void report(const TaskControl& control, double fraction, const std::string& message) {
  if (control.progress) control.progress(fraction, message);
}

}  // namespace

QString importFileFilter(ImportKind kind) {
  switch (kind) {
    case ImportKind::CtImage:
      return QStringLiteral("Images (*.nrrd *.nhdr *.nii *.nii.gz *.mha *.mhd *.dcm);;All files (*)");
    case ImportKind::Mesh: return QStringLiteral("Meshes (*.stl *.vtp *.vtk *.obj *.ply);;All files (*)");
    case ImportKind::Landmarks: return QStringLiteral("Landmarks (*.json *.fcsv *.csv *.txt);;All files (*)");
    case ImportKind::Sequence: return QStringLiteral("PLUS sequences (*.seq.nrrd *.seq.mha *.mha);;All files (*)");
  }
  return QStringLiteral("All files (*)");
}

std::string importRecordName(ImportKind kind) {
  switch (kind) {
    case ImportKind::CtImage: return "import-ct";
    case ImportKind::Mesh: return "import-mesh";
    case ImportKind::Landmarks: return "import-landmarks";
    case ImportKind::Sequence: return "import-sequence";
  }
  return "import";
}

TaskOutcome importIntoSession(ImportKind kind, const fs::path& file, const fs::path& session_folder,
                              const TaskControl& control) {
  if (kind != ImportKind::Sequence) {
    throw InvalidArgumentError("Import: CT images, models and landmarks are imported by their workflow steps "
                               "(import-ct, import-model, find-fiducials)");
  }
  if (!fs::is_regular_file(file)) {
    throw FileError("Import: '" + file.string() + "' is not a readable file. Choose an existing file.");
  }
  TaskOutcome outcome;
  report(control, 0.1, "reading " + file.filename().string());
  auto& f = outcome.figures;
  const auto sequence = io::readSequenceHeader(file);
  f["frames"] = sequence.frames.size();
  f["transforms"] = sequence.transformNames();
  if (control.cancel && control.cancel->load()) {
    outcome.summary = QStringLiteral("import cancelled");
    return outcome;
  }
  report(control, 0.7, "copying into the session");
  const fs::path relative = fs::path("imported") / file.filename();
  const fs::path target = session_folder / relative;
  std::error_code ec;
  fs::create_directories(target.parent_path(), ec);
  if (fs::weakly_canonical(file, ec) != fs::weakly_canonical(target, ec)) {
    fs::copy_file(file, target, fs::copy_options::overwrite_existing, ec);
    if (ec) {
      throw FileError("Import: copying '" + file.string() + "' to '" + target.string() + "' failed (" + ec.message() +
                      "). Check the session folder's permissions and free space.");
    }
  }
  outcome.ok = true;
  outcome.outputs.push_back(relative.generic_string());
  outcome.summary = QString::fromStdString("imported " + file.filename().string());
  report(control, 1.0, "done");
  return outcome;
}

const TriangleMesh& SceneFileCache::mesh(const fs::path& file) {
  std::error_code ec;
  const auto stamp = fs::last_write_time(file, ec);
  if (ec) throw FileError("'" + file.string() + "' is missing from the session folder: make or import it again");
  auto it = meshes_.find(file.string());
  if (it == meshes_.end() || it->second.first != stamp) {
    it = meshes_.insert_or_assign(file.string(), std::make_pair(stamp, io::readMesh(file))).first;
  }
  return it->second.second;
}

bool SceneFileCache::volumeChanged(const fs::path& file) {
  std::error_code ec;
  const auto stamp = fs::last_write_time(file, ec);
  const bool changed = volume_file_ != file.string() || volume_stamp_ != stamp;
  volume_file_ = file.string();
  volume_stamp_ = stamp;
  return changed;
}

void SceneFileCache::forgetVolume() {
  volume_file_.clear();
}

std::string sceneName(const workflow::ModelEntry& model) {
  switch (model.role) {
    case workflow::ModelRole::Bone:
    case workflow::ModelRole::Fiducial: return "vertebra:" + model.id;
    default: return "tissue:" + model.id;
  }
}

Eigen::Vector3d screwColor(const workflow::PlannedScrew& screw) {
  // The plan's own figures colour it: green in bone, amber for a small breach or a close structure, red beyond.
  const auto& f = screw.figures;
  std::string grade = "A";
  if (f.contains("breach") && f["breach"].is_object()) grade = f["breach"].value("grade", "A");
  bool cuts = false;
  if (f.contains("clearance") && f["clearance"].is_object()) {
    for (const char* kind : {"vessel", "neural"}) {
      if (f["clearance"].contains(kind) && f["clearance"][kind].is_object() &&
          f["clearance"][kind].value("min_clearance_mm", 1e9) < 0.0) {
        cuts = true;
      }
    }
  }
  if (cuts || grade >= "C") return {0.95, 0.25, 0.2};
  if (grade == "B") return {0.95, 0.75, 0.2};
  return {0.30, 0.85, 0.45};
}

std::map<std::string, TriangleMesh> loadSessionScene(const workflow::Session& session, rendering::Scene& scene,
                                                     rendering::SliceViews& slices, SceneFileCache& cache) {
  std::map<std::string, TriangleMesh> for_headset;
  std::vector<std::string> problems;
  if (!session.ct() && slices.hasVolume()) {
    slices.clearVolume();
    cache.forgetVolume();
  }
  if (const auto ct = session.ct()) {
    try {
      const fs::path file = session.resolve(ct->file);
      if (cache.volumeChanged(file) || !slices.hasVolume()) {
        slices.setVolume(io::readImage(file));
        slices.setWindowLevel(400.0, 40.0);
      }
    } catch (const mrsns::Error& e) {
      cache.forgetVolume();
      problems.push_back(e.what());
    }
  }
  for (const auto& model : session.models()) {
    try {
      const std::string name = sceneName(model);
      const TriangleMesh& mesh = cache.mesh(session.resolve(model.file));
      // Vessels and nerves stay opaque: they are what the drill must avoid, so they must not fade into the tissue.
      scene.setMesh(name, mesh, model.color, model.opacity);
      scene.setVisible(name, model.visible);
      TriangleMesh light = model.hmd_file.empty() ? mesh : cache.mesh(session.resolve(model.hmd_file));
      light.frame = "CT";
      for_headset[name] = std::move(light);
    } catch (const mrsns::Error& e) {
      problems.push_back("model " + model.id + ": " + e.what());
    }
  }
  for (const auto& screw : session.plans()) {
    try {
      const Eigen::Vector3d direction = (screw.target - screw.entry).normalized();
      const double length = screw.length_mm > 0.0 ? screw.length_mm : (screw.target - screw.entry).norm();
      const Eigen::Vector3d tip = screw.entry + length * direction;
      const Eigen::Vector3d rgb = screwColor(screw);
      scene.setScrewPath("path:" + screw.name, screw.entry, tip, screw.diameter_mm, rgb);
      // The approach axis 30 mm out of the entry: the screw itself runs inside the bone, the axis shows from
      // outside where the drill must come from.
      scene.setScrewPath("path:" + screw.name + " approach", screw.entry - 30.0 * direction, screw.entry, 1.2, rgb);
    } catch (const mrsns::Error& e) {
      problems.push_back("screw " + screw.name + ": " + e.what());
    }
  }
  if (const auto fiducials = session.fiducials()) {
    for (const auto& f : fiducials->points) {
      scene.setMesh("path:fiducial " + f.label, rendering::sphereMesh(f.position_ct, 1.5),
                    Eigen::Vector3d(0.3, 0.8, 1.0), 1.0);
    }
  }
  if (!problems.empty()) {
    std::string text = "The session refers to files that could not be shown:";
    for (const auto& p : problems) text += "\n- " + p;
    text += "\nThe rest of the session is usable; re-import or regenerate these files.";
    throw FormatError(text);
  }
  return for_headset;
}

void applyLayerVisibility(rendering::Scene& scene, DisplayLayer layer, bool visible) {
  const char* prefix = "";
  switch (layer) {
    case DisplayLayer::Vertebrae: prefix = "vertebra:"; break;
    case DisplayLayer::SoftTissue: prefix = "tissue:"; break;
    case DisplayLayer::PlannedPaths: prefix = "path:"; break;
    case DisplayLayer::Tools: prefix = "tool:"; break;
    case DisplayLayer::Ultrasound: prefix = "us:"; break;
    case DisplayLayer::SliceViews: return;
  }
  for (const auto& name : scene.names()) {
    if (name.rfind(prefix, 0) == 0) scene.setVisible(name, visible);
  }
}

}  // namespace mrsns::gui
