// Read throughput of PLUS sequence files (MB/s of decompressed pixel data):
// our reader (full read and frame-by-frame streaming) against ITK's own
// MetaImage reader on the same files: the real zlib-compressed recording and
// an uncompressed copy of it written to a temporary folder.
//   build/tests/benchmarks/mrsns_bench_sequence_read
#include <benchmark/benchmark.h>
#include <itkImage.h>
#include <itkImageFileReader.h>
#include <itkMetaImageIO.h>
#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <optional>
#include <string>

#include "mrsns/io/sequence_file.h"

namespace {

constexpr const char* kRelative = "plus/fCal_Test_Calibration_3NWires.igs.mha";

std::optional<std::filesystem::path> calibrationFile() {
  const char* env = std::getenv("MRSNS_DATA_DIR");
  const std::filesystem::path dir = env ? env : MRSNS_BENCH_DATA_DIR;
  const auto path = dir / kRelative;
  std::error_code ec;
  if (!std::filesystem::is_regular_file(path, ec)) return std::nullopt;
  return path;
}

std::string missingMessage() {
  return std::string("shared data file '") + kRelative + "' not found (set MRSNS_DATA_DIR); benchmark skipped";
}

// The uncompressed copy, written once per process and removed at exit.
std::optional<std::filesystem::path> uncompressedCopy() {
  static const std::optional<std::filesystem::path> copy = []() -> std::optional<std::filesystem::path> {
    const auto source = calibrationFile();
    if (!source) return std::nullopt;
    const auto dir = std::filesystem::temp_directory_path() / ("mrsns-bench-" + std::to_string(::getpid()));
    std::filesystem::create_directories(dir);
    const auto path = dir / "calibration_raw.igs.mha";
    mrsns::io::SequenceWriteOptions options;
    options.compress = false;
    mrsns::io::writeSequence(path, mrsns::io::readSequence(*source), options);
    std::atexit([] {
      std::error_code ec;
      std::filesystem::remove_all(
          std::filesystem::temp_directory_path() / ("mrsns-bench-" + std::to_string(::getpid())), ec);
    });
    return path;
  }();
  return copy;
}

std::optional<std::filesystem::path> input(bool compressed) {
  return compressed ? calibrationFile() : uncompressedCopy();
}

void mrsnsFullRead(benchmark::State& state, bool compressed) {
  const auto path = input(compressed);
  if (!path) return state.SkipWithError(missingMessage().c_str());
  std::int64_t bytes = 0;
  for (auto _ : state) {
    const auto seq = mrsns::io::readSequence(*path);
    benchmark::DoNotOptimize(seq.frames.back().pixels.data());
    bytes += static_cast<std::int64_t>(seq.frames.size() * seq.frameBytes());
  }
  state.SetBytesProcessed(bytes);
}

void mrsnsStreaming(benchmark::State& state, bool compressed) {
  const auto path = input(compressed);
  if (!path) return state.SkipWithError(missingMessage().c_str());
  std::int64_t bytes = 0;
  for (auto _ : state) {
    mrsns::io::SequenceReader reader(*path);
    std::vector<std::uint8_t> frame(reader.frameBytes());
    for (std::size_t i = 0; i < reader.frameCount(); ++i) {
      reader.readFramePixels(i, frame);
      benchmark::DoNotOptimize(frame.data());
    }
    bytes += static_cast<std::int64_t>(reader.frameCount() * reader.frameBytes());
  }
  state.SetBytesProcessed(bytes);
}

void itkRead(benchmark::State& state, bool compressed) {
  const auto path = input(compressed);
  if (!path) return state.SkipWithError(missingMessage().c_str());
  using Image = itk::Image<unsigned char, 3>;
  std::int64_t bytes = 0;
  for (auto _ : state) {
    auto reader = itk::ImageFileReader<Image>::New();
    reader->SetImageIO(itk::MetaImageIO::New());
    reader->SetFileName(path->string());
    reader->Update();
    const Image* image = reader->GetOutput();
    benchmark::DoNotOptimize(image->GetBufferPointer());
    const auto size = image->GetLargestPossibleRegion().GetSize();
    bytes += static_cast<std::int64_t>(size[0] * size[1] * size[2]);
  }
  state.SetBytesProcessed(bytes);
}

void mrsnsHeaderOnly(benchmark::State& state) {
  const auto path = calibrationFile();
  if (!path) return state.SkipWithError(missingMessage().c_str());
  for (auto _ : state) {
    const auto seq = mrsns::io::readSequenceHeader(*path);
    benchmark::DoNotOptimize(seq.frames.data());
  }
}

BENCHMARK_CAPTURE(mrsnsFullRead, zlib, true)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK_CAPTURE(mrsnsStreaming, zlib, true)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK_CAPTURE(itkRead, zlib, true)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK_CAPTURE(mrsnsFullRead, raw, false)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK_CAPTURE(mrsnsStreaming, raw, false)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK_CAPTURE(itkRead, raw, false)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(mrsnsHeaderOnly)->Unit(benchmark::kMillisecond)->UseRealTime();

}  // namespace

BENCHMARK_MAIN();
