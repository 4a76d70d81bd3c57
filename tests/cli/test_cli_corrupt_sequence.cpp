// A sequence whose header claims more frames than the file holds, through
// the real binary: exit 1 and one line naming the file, for info and
// convert, and the output of a failed convert is not left behind.
#include <gtest/gtest.h>

#include <fstream>
#include <sstream>

#include "../io/test_sequence_util.h"
#include "cli_runner.h"
#include "test_data.h"

namespace mrsns::test {
namespace {

TEST(CliCorruptSequence, HeaderLyingAboutFrameCountExitsOne) {
  const auto dir = scratchDirectory("lying");
  io::SequenceWriteOptions options;
  options.compress = false;
  io::writeSequence(dir / "ok.igs.mha", makeSyntheticSequence(4), options);
  std::ifstream in(dir / "ok.igs.mha", std::ios::binary);
  std::stringstream buffer;
  buffer << in.rdbuf();
  std::string bytes = buffer.str();
  const auto pos = bytes.find("DimSize = 13 7 4");
  ASSERT_NE(pos, std::string::npos);
  bytes.replace(pos, 16, "DimSize = 13 7 9");  // 9 frames claimed, 4 present
  std::ofstream(dir / "lying.igs.mha", std::ios::binary) << bytes;

  for (const std::vector<std::string>& args :
       {std::vector<std::string>{"info", (dir / "lying.igs.mha").string()},
        std::vector<std::string>{"info", "--json", (dir / "lying.igs.mha").string()},
        std::vector<std::string>{"convert", (dir / "lying.igs.mha").string(), (dir / "out.seq.nrrd").string()}}) {
    const auto result = runCli(args);
    EXPECT_EQ(result.exit_code, 1) << args[0];
    EXPECT_TRUE(result.out.empty()) << result.out;
    EXPECT_NE(result.err.find("lying.igs.mha"), std::string::npos) << result.err;
    EXPECT_EQ(result.err.find('\n'), result.err.size() - 1) << "one line: " << result.err;
  }
  EXPECT_FALSE(std::filesystem::exists(dir / "out.seq.nrrd"));
  // The intact file still works.
  EXPECT_EQ(runCli({"info", (dir / "ok.igs.mha").string()}).exit_code, 0);
}

}  // namespace
}  // namespace mrsns::test
