// Shared pieces of the preparation steps on the patient's data (patient_data.h).
#include "patient_data.h"

#include <filesystem>

#include "mrsns/core/error.h"
#include "mrsns/core/mesh_ops.h"
#include "mrsns/io/image_io.h"
#include "mrsns/io/mesh_io.h"
#include "mrsns/registration/label_meshing.h"
#include "time_text.h"

namespace mrsns::workflow::detail {

namespace fs = std::filesystem;

Provenance madeBy(const std::string& step, const std::string& file) {
  Provenance p;
  p.source = file.empty() ? "step" : "file";
  p.step = step;
  p.file = file;
  p.time = isoTimeNow();
  return p;
}

ImageVolume loadSessionCt(const Session& session, const std::string& step) {
  const auto ct = session.ct();
  if (!ct) {
    throw InvalidArgumentError(step + ": the session has no CT: import the patient's CT first (step import-ct, or "
                                      "Data > Import CT in the GUI)");
  }
  const fs::path file = session.resolve(ct->file);
  std::error_code ec;
  if (!fs::exists(file, ec)) {
    throw FileError(step + ": the session's CT file '" + ct->file +
                    "' is missing from the session folder: import the CT again (import-ct replace=true)");
  }
  ImageVolume image = io::readImage(file);
  image.frame = ct->frame;
  image.name = ct->name;
  return image;
}

ImageVolume loadSessionLabelMap(const Session& session, const LabelMapEntry& labels) {
  const fs::path file = session.resolve(labels.file);
  std::error_code ec;
  if (!fs::exists(file, ec)) {
    throw FileError("the label map file '" + labels.file + "' (" + labels.id +
                    ") is missing from the session folder: import it again (import-label-map)");
  }
  ImageVolume image = io::readImage(file);
  image.frame = "CT";
  image.name = labels.name.empty() ? labels.id : labels.name;
  return image;
}

LabelMapEntry sessionLabelMap(const Session& session, const std::string& id, const std::string& step) {
  const auto maps = session.labelMaps();
  if (maps.empty()) {
    throw InvalidArgumentError(step + ": the session has no label map: import one first (step import-label-map, e.g. "
                                      "TotalSegmentator's output for this CT)");
  }
  if (id.empty()) return maps.back();
  std::string ids;
  for (const auto& m : maps) {
    if (m.id == id) return m;
    ids += (ids.empty() ? "" : ", ") + m.id;
  }
  throw InvalidArgumentError(step + ": the session has no label map '" + id + "' (it has: " + ids + ")");
}

ModelEntry writeModelFiles(const Session& session, const TriangleMesh& mesh, ModelEntry entry,
                           std::size_t hmd_triangles, std::vector<std::string>& outputs) {
  if (mesh.empty()) throw ComputationError("model '" + entry.name + "' has no triangle: nothing to show");
  TriangleMesh full = mesh;
  full.name = entry.name;
  full.frame = entry.frame;
  entry.file = "models/" + entry.id + ".vtp";
  fs::create_directories(session.resolve("models"));
  io::writeMesh(full, session.resolve(entry.file));
  outputs.push_back(entry.file);
  entry.triangles = static_cast<std::size_t>(full.faceCount());
  entry.volume_ml = isClosed(full) ? signedVolume(full) / 1000.0 : 0.0;
  entry.hmd_file.clear();
  entry.hmd_triangles = 0;
  if (hmd_triangles > 0) {
    // A headset renders every triangle of every hologram at 60 Hz on a mobile GPU: it gets a light copy.
    const TriangleMesh light =
        entry.triangles > hmd_triangles ? registration::decimateMesh(full, hmd_triangles) : full;
    entry.hmd_file = "models/hmd/" + entry.id + ".vtp";
    fs::create_directories(session.resolve("models/hmd"));
    io::writeMesh(light, session.resolve(entry.hmd_file));
    outputs.push_back(entry.hmd_file);
    entry.hmd_triangles = static_cast<std::size_t>(light.faceCount());
  }
  return entry;
}

Eigen::Vector3d pointParam(const Json& params, const std::string& key, const std::string& step) {
  const auto fail = [&](const std::string& got) -> Eigen::Vector3d {
    throw InvalidArgumentError(step + ": parameter '" + key + "' = " + got +
                               " is not a point: give \"x,y,z\" in mm (LPS, the CT's frame)");
  };
  if (!params.contains(key)) fail("(missing)");
  const Json& v = params.at(key);
  if (v.is_array()) {
    if (v.size() != 3 || !v[0].is_number() || !v[1].is_number() || !v[2].is_number()) return fail(v.dump());
    Eigen::Vector3d p(v[0].get<double>(), v[1].get<double>(), v[2].get<double>());
    if (!p.allFinite()) return fail(v.dump());
    return p;
  }
  if (!v.is_string()) return fail(v.dump());
  std::string text = v.get<std::string>();
  for (auto& c : text) {
    if (c == ',' || c == ';') c = ' ';
  }
  Eigen::Vector3d p;
  std::size_t used = 0;
  try {
    std::size_t offset = 0;
    for (int a = 0; a < 3; ++a) {
      const std::string rest = text.substr(offset);
      p[a] = std::stod(rest, &used);
      offset += used;
    }
    if (text.find_first_not_of(" \t", offset) != std::string::npos) return fail("\"" + v.get<std::string>() + "\"");
  } catch (const std::exception&) {
    return fail("\"" + v.get<std::string>() + "\"");
  }
  if (!p.allFinite()) return fail("\"" + v.get<std::string>() + "\"");
  return p;
}

Eigen::AlignedBox3d ctBounds(const ImageEntry& ct) {
  Eigen::AlignedBox3d box;
  const Eigen::Matrix3d m = ct.direction * ct.spacing_mm.asDiagonal();
  for (int corner = 0; corner < 8; ++corner) {
    Eigen::Vector3d ijk;
    for (int a = 0; a < 3; ++a) ijk[a] = (corner >> a & 1) ? ct.size_px[static_cast<std::size_t>(a)] - 0.5 : -0.5;
    box.extend(ct.origin_mm + m * ijk);
  }
  return box;
}

}  // namespace mrsns::workflow::detail
