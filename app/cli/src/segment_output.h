#pragma once
// Shared by `segment` and `make-phantom`: writes label meshes into a folder
// and describes them in the verb's JSON report.
#include <filesystem>
#include <string>

#include "cli_context.h"
#include "mrsns/registration/label_meshing.h"

namespace mrsns::cli {

/// A file name made of the label name ("vertebrae_L1" -> "vertebrae_L1.stl");
/// characters other than letters, digits, '-' and '_' become '_'.
std::string meshFileName(const std::string& name, const std::string& extension);

/// Writes each mesh as DIR/<name>.<extension> and returns one JSON object per
/// mesh (label, name, colour, file, volumes, triangles, closed); appends one
/// line per mesh to `text`.
Json writeLabelMeshes(const registration::LabelMeshingResult& result, const std::filesystem::path& dir,
                      const std::string& extension, std::string& text);

Json vector3Json(const Eigen::Vector3d& v);

}  // namespace mrsns::cli
