// Session folder: create, record, reopen, refuse corrupt or foreign state.
#include <gtest/gtest.h>

#include <fstream>

#include "mrsns/core/error.h"
#include "mrsns/workflow/session.h"
#include "test_data.h"

namespace mrsns::workflow {
namespace {

void writeText(const std::filesystem::path& p, const std::string& text) {
  std::ofstream out(p, std::ios::binary | std::ios::trunc);
  out << text;
}

TEST(Session, CreateRecordReopenKeepsEveryStep) {
  const auto dir = test::scratchDirectory("s") / "session";
  {
    auto session = Session::create(dir);
    EXPECT_EQ(session.state()["version"], kSessionVersion);
    session.recordStep("registration", {{"status", "ok"}, {"figures", {{"fre_rms_mm", 0.42}}}});
    session.recordStep("navigation", {{"status", "failed"}});
    session.log("warn", "robot stopped: tracking lost");
  }
  const auto reopened = Session::open(dir);
  EXPECT_EQ(reopened.step("registration")["figures"]["fre_rms_mm"], 0.42);
  EXPECT_EQ(reopened.step("navigation")["status"], "failed");
  EXPECT_TRUE(reopened.step("hmd-calibration").is_null());
  ASSERT_EQ(reopened.state()["log"].size(), 1u);
  EXPECT_EQ(reopened.state()["log"][0]["message"], "robot stopped: tracking lost");
  EXPECT_FALSE(std::filesystem::exists(dir / "session.json.tmp")) << "the temporary file of the atomic save remains";
}

TEST(Session, CreateRefusesANonEmptyFolder) {
  const auto dir = test::scratchDirectory("s");
  writeText(dir / "something.txt", "x");
  EXPECT_THROW(Session::create(dir), FileError);
  // An existing empty folder is fine.
  std::filesystem::create_directories(dir / "empty");
  EXPECT_NO_THROW(Session::create(dir / "empty"));
}

TEST(Session, OpenRefusesMissingCorruptAndForeignStateWithClearMessages) {
  const auto dir = test::scratchDirectory("s");
  try {
    Session::open(dir / "nothing");
    FAIL() << "opened a folder without session.json";
  } catch (const FileError& e) {
    EXPECT_NE(std::string(e.what()).find("session create"), std::string::npos) << e.what();
  }
  auto session = Session::create(dir / "a");
  // Truncated mid-write by another program (our own saves are atomic).
  writeText(dir / "a" / "session.json", R"({"version": 1, "steps": {"regis)");
  try {
    Session::open(dir / "a");
    FAIL() << "opened truncated JSON";
  } catch (const FormatError& e) {
    EXPECT_NE(std::string(e.what()).find("not valid JSON"), std::string::npos) << e.what();
  }
  writeText(dir / "a" / "session.json", R"({"steps": {}})");
  EXPECT_THROW(Session::open(dir / "a"), FormatError);
  writeText(dir / "a" / "session.json", R"({"version": 99, "steps": {}})");
  try {
    Session::open(dir / "a");
    FAIL() << "opened a future version";
  } catch (const FormatError& e) {
    EXPECT_NE(std::string(e.what()).find("version 99"), std::string::npos) << e.what();
  }
  writeText(dir / "a" / "session.json", R"({"version": 1, "steps": []})");
  EXPECT_THROW(Session::open(dir / "a"), FormatError);
  writeText(dir / "a" / "session.json", R"([1, 2])");
  EXPECT_THROW(Session::open(dir / "a"), FormatError);
}

TEST(Session, ResolveKeepsFilesInsideTheFolder) {
  const auto dir = test::scratchDirectory("s") / "x";
  const auto session = Session::create(dir);
  EXPECT_EQ(session.resolve("navigation/tracking_1.mhd"), session.folder() / "navigation" / "tracking_1.mhd");
  EXPECT_THROW(static_cast<void>(session.resolve("../escape.txt")), InvalidArgumentError);
  EXPECT_THROW(static_cast<void>(session.resolve("/etc/passwd")), InvalidArgumentError);
  EXPECT_THROW(static_cast<void>(session.resolve("")), InvalidArgumentError);
}

}  // namespace
}  // namespace mrsns::workflow
