#include <gtest/gtest.h>

#include <cstdlib>

#include "mrsns/core/data_dir.h"
#include "mrsns/core/error.h"
#include "mrsns/core/log.h"
#include "mrsns/core/transform_status.h"

namespace mrsns {
namespace {

TEST(Errors, AreCatchableAsMrsnsErrorWithTheirMessage) {
  try {
    throw FormatError("file 'a.mha': DimSize missing");
  } catch (const Error& e) {
    EXPECT_STREQ(e.what(), "file 'a.mha': DimSize missing");
  }
  EXPECT_THROW(throw ComputationError("x"), Error);
  EXPECT_THROW(throw FrameError("x"), std::runtime_error);
}

TEST(Logging, AcceptsKnownLevelsAndRejectsUnknown) {
  EXPECT_NO_THROW(setLogLevel("debug"));
  EXPECT_EQ(logger()->level(), spdlog::level::debug);
  EXPECT_NO_THROW(setLogLevel("off"));
  EXPECT_EQ(logger()->level(), spdlog::level::off);
  EXPECT_THROW(setLogLevel("loud"), InvalidArgumentError);
  setLogLevel("warn");
}

TEST(DataDirectory, EnvironmentOverridesBuildDefault) {
  const char* old = std::getenv("MRSNS_DATA_DIR");
  const std::string saved = old ? old : "";
  ::setenv("MRSNS_DATA_DIR", "/nonexistent/mrsns-data", 1);
  EXPECT_EQ(dataDirectory(), std::filesystem::path("/nonexistent/mrsns-data"));
  EXPECT_FALSE(findDataFile("plus").has_value());
  if (old)
    ::setenv("MRSNS_DATA_DIR", saved.c_str(), 1);
  else
    ::unsetenv("MRSNS_DATA_DIR");
}

TEST(TransformStatusNames, FollowPlusSpellingAndOrder) {
  EXPECT_EQ(toString(TransformStatus::Ok), "OK");
  EXPECT_EQ(toString(TransformStatus::Invalid), "INVALID");
  EXPECT_EQ(worse(TransformStatus::Ok, TransformStatus::Invalid), TransformStatus::Invalid);
  EXPECT_EQ(worse(TransformStatus::Missing, TransformStatus::Invalid), TransformStatus::Missing);
  EXPECT_EQ(worse(TransformStatus::Ok, TransformStatus::Ok), TransformStatus::Ok);
}

}  // namespace
}  // namespace mrsns
