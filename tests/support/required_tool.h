// A test's external program (gdcmanon, dcm2niix) found on PATH: the test is
// skipped without it, and fails under CI, where scripts/debian-packages.txt
// installs it.
#pragma once

#include <gtest/gtest.h>
#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <sstream>
#include <string>

#include "test_data.h"

namespace mrsns::test {

/// `name` on PATH, or an empty path.
inline std::filesystem::path toolOnPath(const std::string& name) {
  const char* path = std::getenv("PATH");
  std::istringstream dirs(path != nullptr ? path : "");
  std::string dir;
  while (std::getline(dirs, dir, ':')) {
    if (dir.empty()) continue;
    const auto candidate = std::filesystem::path(dir) / name;
    std::error_code ec;
    if (std::filesystem::is_regular_file(candidate, ec) && ::access(candidate.c_str(), X_OK) == 0) return candidate;
  }
  return {};
}

/// Declares `var` as the program `name` found on PATH, or skips the test (fails it under CI, where
/// scripts/debian-packages.txt installs it: gdcmanon from libgdcm-tools, dcm2niix).
#define MRSNS_REQUIRE_TOOL(var, name)                                                                       \
  const std::filesystem::path var = ::mrsns::test::toolOnPath(name);                                                  \
  if (var.empty()) {                                                                                        \
    if (::mrsns::test::missingDataFails())                                                                  \
      FAIL() << "'" name                                                                                    \
                "' is not on PATH (install it: apt-get install "                                            \
                "it, see scripts/debian-packages.txt)";                                                     \
    GTEST_SKIP() << "'" name "' is not on PATH: install it (scripts/debian-packages.txt) to run this test"; \
  }

}  // namespace mrsns::test
