#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include "cli_runner.h"

namespace mrsns::test {
namespace {

TEST(CliBasics, HelpListsEveryVerbAndExitsZero) {
  const auto result = runCli({"--help"});
  EXPECT_EQ(result.exit_code, 0);
  EXPECT_NE(result.out.find("info"), std::string::npos);
  EXPECT_NE(result.out.find("convert"), std::string::npos);
}

TEST(CliBasics, EachVerbHasHelp) {
  for (const std::string verb : {"info", "convert"}) {
    const auto result = runCli({verb, "--help"});
    EXPECT_EQ(result.exit_code, 0) << verb;
    EXPECT_NE(result.out.find("--json"), std::string::npos) << verb;
  }
}

TEST(CliBasics, VersionPrintsProjectVersion) {
  const auto result = runCli({"--version"});
  EXPECT_EQ(result.exit_code, 0);
  EXPECT_NE(result.out.find("mrsns-cli 0."), std::string::npos) << result.out;
}

TEST(CliBasics, UsageErrorsExitTwo) {
  EXPECT_EQ(runCli({}).exit_code, 2);
  EXPECT_EQ(runCli({"no-such-verb"}).exit_code, 2);
  EXPECT_EQ(runCli({"info"}).exit_code, 2);
  EXPECT_EQ(runCli({"info", "--no-such-flag", "x"}).exit_code, 2);
}

TEST(CliBasics, MissingFileExitsOneWithOneLineMessage) {
  const auto result = runCli({"info", "--json", "/nonexistent/file.stl"});
  EXPECT_EQ(result.exit_code, 1);
  EXPECT_TRUE(result.out.empty()) << result.out;
  EXPECT_NE(result.err.find("does not exist"), std::string::npos) << result.err;
  EXPECT_EQ(result.err.find('\n'), result.err.size() - 1) << "message must be one line: " << result.err;
}

TEST(CliBasics, UnknownFileKindExitsOne) {
  const auto dir = std::filesystem::temp_directory_path() / "mrsns-cli-basics";
  std::filesystem::create_directories(dir);
  const auto path = dir / "notes.docx";
  std::ofstream(path) << "hello";
  const auto result = runCli({"info", path.string()});
  EXPECT_EQ(result.exit_code, 1);
  EXPECT_NE(result.err.find("not a file kind"), std::string::npos) << result.err;
}

TEST(CliBasics, ConvertRefusesDifferentKinds) {
  const auto dir = std::filesystem::temp_directory_path() / "mrsns-cli-basics";
  std::filesystem::create_directories(dir);
  const auto path = dir / "points.fcsv";
  std::ofstream(path) << "# Markups fiducial file version = 4.11\n# CoordinateSystem = LPS\n";
  const auto result = runCli({"convert", path.string(), (dir / "out.stl").string()});
  EXPECT_EQ(result.exit_code, 1);
  EXPECT_NE(result.err.find("cannot convert"), std::string::npos) << result.err;
}

}  // namespace
}  // namespace mrsns::test
