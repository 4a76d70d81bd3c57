#include "mrsns/core/data_dir.h"

#include <cstdlib>

namespace mrsns {

std::filesystem::path dataDirectory() {
  if (const char* env = std::getenv("MRSNS_DATA_DIR"); env != nullptr && *env != '\0') {
    return std::filesystem::path(env);
  }
  return std::filesystem::path(MRSNS_DEFAULT_DATA_DIR);
}

std::optional<std::filesystem::path> findDataFile(const std::string& relative) {
  const auto candidate = dataDirectory() / relative;
  std::error_code ec;
  if (std::filesystem::exists(candidate, ec)) {
    return candidate.lexically_normal();
  }
  return std::nullopt;
}

const char* versionString() {
  return MRSNS_VERSION;
}

}  // namespace mrsns
