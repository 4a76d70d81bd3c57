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
#include "mrsns/workflow/session.h"

namespace mrsns::gui {
namespace fs = std::filesystem;

namespace {

bool isMeshFile(const fs::path& p) {
  const std::string name = io::lowerFileName(p);
  for (const char* ext : {".stl", ".vtp", ".vtk", ".obj", ".ply"}) {
    if (io::endsWith(name, ext)) return true;
  }
  return false;
}

bool isSequenceFile(const fs::path& p) {
  const std::string name = io::lowerFileName(p);
  return io::endsWith(name, ".seq.nrrd") || io::endsWith(name, ".seq.mha") || io::endsWith(name, ".seq.mhd");
}

bool isVolumeFile(const fs::path& p) {
  if (isSequenceFile(p)) return false;
  const std::string name = io::lowerFileName(p);
  for (const char* ext : {".nrrd", ".nhdr", ".nii", ".nii.gz", ".mha", ".mhd"}) {
    if (io::endsWith(name, ext)) return true;
  }
  return false;
}

bool isSoftTissue(const std::string& lower_name) {
  for (const char* word : {"tissue", "soft", "skin", "muscle", "vessel", "artery", "posterior", "shape"}) {
    if (lower_name.find(word) != std::string::npos) return true;
  }
  return false;
}

bool isVessel(const std::string& lower_name) {
  for (const char* word : {"vessel", "artery", "carotid", "vein"}) {
    if (lower_name.find(word) != std::string::npos) return true;
  }
  return false;
}

/// Every string in the state (recursively), in document order without repeats.
void collectStrings(const nlohmann::json& j, std::vector<std::string>& out, std::set<std::string>& seen) {
  if (j.is_string()) {
    const auto& s = j.get_ref<const std::string&>();
    if (!s.empty() && s.size() < 1024 && seen.insert(s).second) out.push_back(s);
  } else if (j.is_structured()) {
    for (const auto& e : j) collectStrings(e, out, seen);
  }
}

std::optional<Eigen::Vector3d> vector3(const nlohmann::json& object, const char* key) {
  if (!object.is_object() || !object.contains(key)) return std::nullopt;
  const auto& v = object[key];
  if (!v.is_array() || v.size() != 3 || !v[0].is_number() || !v[1].is_number() || !v[2].is_number()) {
    return std::nullopt;
  }
  return Eigen::Vector3d(v[0].get<double>(), v[1].get<double>(), v[2].get<double>());
}

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
  if (!fs::is_regular_file(file)) {
    throw FileError("Import: '" + file.string() + "' is not a readable file. Choose an existing file.");
  }
  TaskOutcome outcome;
  report(control, 0.1, "reading " + file.filename().string());
  auto& f = outcome.figures;
  switch (kind) {
    case ImportKind::CtImage: {
      const auto read = io::readImageFile(file);
      f["size_px"] = {read.image.size[0], read.image.size[1], read.image.size[2]};
      f["spacing_mm"] = {read.image.spacing.x(), read.image.spacing.y(), read.image.spacing.z()};
      f["format"] = io::imageFormatName(read.format);
      break;
    }
    case ImportKind::Mesh: {
      const auto mesh = io::readMesh(file);
      f["vertices"] = mesh.vertexCount();
      f["triangles"] = mesh.faceCount();
      break;
    }
    case ImportKind::Landmarks: {
      const auto read = io::readLandmarksFile(file);
      f["points"] = read.landmarks.size();
      break;
    }
    case ImportKind::Sequence: {
      const auto sequence = io::readSequenceHeader(file);
      f["frames"] = sequence.frames.size();
      f["transforms"] = sequence.transformNames();
      break;
    }
  }
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

std::map<std::string, TriangleMesh> loadSessionScene(const workflow::Session& session, rendering::Scene& scene,
                                                     rendering::SliceViews& slices) {
  std::vector<std::string> strings;
  std::set<std::string> seen;
  collectStrings(session.state(), strings, seen);
  std::map<std::string, TriangleMesh> meshes;
  std::vector<std::string> problems;
  bool have_volume = false;
  int path_index = 0;
  for (const auto& s : strings) {
    fs::path file;
    std::error_code ec;
    try {
      file = session.resolve(s);
    } catch (const mrsns::Error&) {
      continue;  // not a path inside the session
    }
    if (!fs::is_regular_file(file, ec)) continue;
    const std::string lower = io::lowerFileName(file);
    try {
      if (isMeshFile(file)) {
        TriangleMesh mesh = io::readMesh(file);
        const bool tissue = isSoftTissue(lower);
        const std::string name = (tissue ? "tissue:" : "vertebra:") + file.stem().string();
        // Vessels belong to the soft-tissue layer but are opaque red: they are
        // what the drill must avoid, so they must not fade into the tissue.
        const bool vessel = isVessel(lower);
        const Eigen::Vector3d color = vessel   ? Eigen::Vector3d(0.80, 0.10, 0.10)
                                      : tissue ? Eigen::Vector3d(0.85, 0.45, 0.42)
                                               : Eigen::Vector3d(0.93, 0.89, 0.80);
        scene.setMesh(name, mesh, color, vessel ? 1.0 : (tissue ? 0.25 : 1.0));
        meshes[name] = std::move(mesh);
      } else if (!have_volume && isVolumeFile(file) && lower.find("label") == std::string::npos) {
        slices.setVolume(io::readImage(file));
        have_volume = true;
      } else if (io::endsWith(lower, ".mrk.json")) {
        // Screw plans are Line markups; fiducial markups are not drawn.
        std::vector<io::MarkupsLine> lines;
        try {
          lines = io::readMarkupsLines(file);
        } catch (const FormatError&) {
          continue;
        }
        for (const auto& line : lines) {
          scene.setScrewPath("path:" + (line.name.empty() ? std::to_string(path_index) : line.name), line.start,
                             line.end, 3.5, Eigen::Vector3d(0.30, 0.75, 0.95));
          ++path_index;
        }
      }
    } catch (const mrsns::Error& e) {
      problems.push_back(e.what());
    }
  }
  // Planned screw paths recorded by the steps (e.g. registration's
  // figures.paths: name, entry_ct, target_ct in CT mm).
  const auto& steps = session.state().contains("steps") ? session.state()["steps"] : nlohmann::json::object();
  for (const auto& [step, record] : steps.items()) {
    if (!record.is_object() || !record.contains("figures") || !record["figures"].is_object()) continue;
    const auto& figures = record["figures"];
    if (!figures.contains("paths") || !figures["paths"].is_array()) continue;
    for (const auto& path : figures["paths"]) {
      const auto entry = vector3(path, "entry_ct");
      const auto target = vector3(path, "target_ct");
      if (!entry || !target) continue;
      const std::string name = path.value("name", std::to_string(path_index));
      scene.setScrewPath("path:" + name, *entry, *target, 3.5, Eigen::Vector3d(0.30, 0.75, 0.95));
      // The approach axis 30 mm out of the entry: the screw itself runs inside
      // the bone, the axis shows from outside where the drill must come from.
      if ((*target - *entry).norm() > 1e-6) {
        const Eigen::Vector3d out = *entry - 30.0 * (*target - *entry).normalized();
        scene.setScrewPath("path:" + name + " approach", out, *entry, 1.2, Eigen::Vector3d(0.30, 0.75, 0.95));
      }
      ++path_index;
    }
  }
  if (!problems.empty()) {
    std::string text = "The session refers to files that could not be shown:";
    for (const auto& p : problems) text += "\n- " + p;
    text += "\nThe rest of the session is usable; re-import or regenerate these files.";
    throw FormatError(text);
  }
  return meshes;
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
