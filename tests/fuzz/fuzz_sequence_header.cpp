// libFuzzer target: sequence-file headers (MetaImage and NRRD) and the reader
// behind them. Any input must either parse or throw an mrsns::Error; a
// header that parses must format and parse back to the same text; the same
// bytes read as a file must never read out of bounds or allocate what a
// header merely claims.
#include <unistd.h>

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>
#include <string_view>

#include "mrsns/core/error.h"
#include "mrsns/core/log.h"
#include "mrsns/io/sequence_file.h"
#include "sequence_internal.h"

namespace {

using namespace mrsns::io;

SequenceReadOptions fuzzLimits() {
  SequenceReadOptions options;
  options.max_frames = 256;
  options.max_frame_bytes = 1 << 16;
  options.max_total_bytes = 1 << 18;
  options.max_header_bytes = 1 << 20;
  return options;
}

detail::ParsedHeader parse(std::string_view text, const SequenceReadOptions& options) {
  return detail::isNrrdText(text) ? detail::parseNrrdHeader(text, "fuzz", options)
                                  : detail::parseMetaImageHeader(text, "fuzz", options);
}

void checkHeaderRoundTrip(std::string_view text, const SequenceReadOptions& options) {
  const auto end =
      detail::isNrrdText(text) ? detail::findNrrdHeaderEnd(text, true) : detail::findMetaImageHeaderEnd(text, true);
  if (!end) return;
  detail::ParsedHeader parsed;
  try {
    parsed = parse(text.substr(0, *end), options);
  } catch (const mrsns::Error&) {
    return;  // rejected with a typed error: fine
  }
  if (detail::isNrrdText(text)) return;  // NRRD keys may hold characters MetaImage cannot; the file test covers NRRD
  // What we write from a header we accepted must read back to the same header.
  const std::string first = detail::formatMetaImageHeader(parsed.sequence, false, std::nullopt, "LOCAL", nullptr);
  const auto again = detail::parseMetaImageHeader(first, "fuzz-rewrite", options);
  const std::string second = detail::formatMetaImageHeader(again.sequence, false, std::nullopt, "LOCAL", nullptr);
  if (first != second) {
    std::fprintf(stderr, "header rewrite is not stable:\n--- first\n%s\n--- second\n%s\n", first.c_str(),
                 second.c_str());
    std::abort();
  }
}

void checkFileRead(const std::uint8_t* data, std::size_t size, const SequenceReadOptions& options) {
  static const std::filesystem::path path =
      std::filesystem::temp_directory_path() / ("mrsns-fuzz-" + std::to_string(::getpid()) + ".mha");
  {
    std::ofstream out(path, std::ios::binary | std::ios::trunc);
    out.write(reinterpret_cast<const char*>(data), static_cast<std::streamsize>(size));
  }
  try {
    (void)readSequence(path, options);
  } catch (const mrsns::Error&) {
  }
}

}  // namespace

extern "C" int LLVMFuzzerInitialize(int*, char***) {
  mrsns::setLogLevel("off");
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const SequenceReadOptions options = fuzzLimits();
  const std::string_view text(reinterpret_cast<const char*>(data), size);
  checkHeaderRoundTrip(text, options);
  checkFileRead(data, size, options);
  return 0;
}
