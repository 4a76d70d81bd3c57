#pragma once
// Access to the shared real-data set from tests. Tests that need a file call
// MRSNS_REQUIRE_DATA and are skipped, with a message naming the file and the
// setting, when it is absent.
#include <gtest/gtest.h>

#include <filesystem>
#include <string>

#include "mrsns/core/data_dir.h"

namespace mrsns::test {

/// A fresh, empty scratch directory for one test (under the build tree's
/// Testing/ folder, or the system temp directory).
inline std::filesystem::path scratchDirectory(const std::string& name) {
  const char* binary = std::getenv("MRSNS_BINARY_DIR");
  if (binary == nullptr) binary = MRSNS_TEST_BINARY_DIR;
  std::filesystem::path base = binary ? std::filesystem::path(binary) / "Testing" / "scratch"
                                      : std::filesystem::temp_directory_path() / "mrsns-tests";
  const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
  std::string dir = name;
  if (info != nullptr) dir = std::string(info->test_suite_name()) + "." + info->name() + "." + name;
  const auto path = base / dir;
  std::filesystem::remove_all(path);
  std::filesystem::create_directories(path);
  return path;
}

}  // namespace mrsns::test

/// Declares `var` (a std::filesystem::path) as the data file `relative`, or skips the test.
#define MRSNS_REQUIRE_DATA(var, relative)                                                                  \
  const auto var##_found = ::mrsns::findDataFile(relative);                                                \
  if (!var##_found) {                                                                                      \
    GTEST_SKIP() << "shared data file '" << (relative) << "' not found under " << ::mrsns::dataDirectory() \
                 << " (set MRSNS_DATA_DIR or the CMake cache variable MRSNS_DATA_DIR)";                    \
  }                                                                                                        \
  const std::filesystem::path var = *var##_found
