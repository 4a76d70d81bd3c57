#pragma once
// Access to the shared real-data set from tests. Tests that need a file call
// MRSNS_REQUIRE_DATA. When the file is absent the test is skipped on a
// developer's machine (a checkout without the data set still builds and tests)
// but fails under CI (environment CI=true, as .ci/run sets it), naming the
// file: a green CI must mean the real-data tests ran.
#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
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

/// True under CI (environment variable CI=true or 1, as .ci/run and most CI
/// services set it): missing shared data is then a failure, not a skip.
/// Writes `bytes` to `path` as they are (corrupt-file and header tests).
inline void writeBytes(const std::filesystem::path& path, const std::string& bytes) {
  std::ofstream out(path, std::ios::binary);
  out << bytes;
}

inline bool missingDataFails() {
  const char* ci = std::getenv("CI");
  return ci != nullptr && (std::string(ci) == "true" || std::string(ci) == "1");
}

/// The message for an absent data file `relative`.
inline std::string missingDataMessage(const std::string& relative) {
  return "shared data file '" + relative + "' not found under " + ::mrsns::dataDirectory().string() +
         " (set MRSNS_DATA_DIR or the CMake cache variable MRSNS_DATA_DIR)";
}

}  // namespace mrsns::test

/// Skips the test (fails it under CI) because the data file `relative` is absent.
#define MRSNS_MISSING_DATA(relative)                                     \
  do {                                                                   \
    if (::mrsns::test::missingDataFails()) {                             \
      FAIL() << ::mrsns::test::missingDataMessage(relative);             \
    }                                                                    \
    GTEST_SKIP() << ::mrsns::test::missingDataMessage(relative);         \
  } while (false)

/// Declares `var` (a std::filesystem::path) as the data file `relative`, or skips the test.
#define MRSNS_REQUIRE_DATA(var, relative)                                                                  \
  const auto var##_found = ::mrsns::findDataFile(relative);                                                \
  if (!var##_found) MRSNS_MISSING_DATA(relative);                                                           \
  const std::filesystem::path var = *var##_found
