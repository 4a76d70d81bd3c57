#pragma once
// Where the real recordings (the shared data set, never copied into the
// repository) are found: the MRSNS_DATA_DIR environment variable, else the
// directory configured at build time (default ../shared/data beside the
// checkout).
#include <filesystem>
#include <optional>
#include <string>

namespace mrsns {

/// The data directory in effect (environment first, then the build default).
std::filesystem::path dataDirectory();

/// dataDirectory()/relative when that file or folder exists, else nullopt.
std::optional<std::filesystem::path> findDataFile(const std::string& relative);

/// The project version, e.g. "0.1.0".
const char* versionString();

}  // namespace mrsns
