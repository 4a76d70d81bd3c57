#pragma once
// Text shared by the readers and writers of this module.
#include <filesystem>
#include <string>

namespace mrsns::io::detail {

/// A path in single quotes, for error messages. (Built by appending: GCC 12
/// reports "'" + std::string as an overlapping copy in some of these files.)
inline std::string quoted(const std::filesystem::path& path) {
  std::string s(1, '\'');
  s += path.string();
  s += '\'';
  return s;
}

/// The JSON schema of 3D Slicer's markups files (.mrk.json) this module writes.
inline constexpr const char* kMarkupsSchema =
    "https://raw.githubusercontent.com/slicer/slicer/master/Modules/Loadable/Markups/Resources/Schema/"
    "markups-schema-v1.0.3.json#";

}  // namespace mrsns::io::detail
