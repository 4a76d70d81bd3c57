#pragma once
// PLUS tracked-frame sequence files: MetaImage (.igs.mha/.seq.mha/.mha with
// the data inline, .mhd with a separate .raw/.zraw) and Slicer/PLUS NRRD
// (.seq.nrrd, raw or gzip). Plain C++ and zlib, so the parsers also build
// with clang for fuzzing. Every size in a header is checked against the data
// actually present before anything is allocated.
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <memory>
#include <optional>
#include <span>
#include <string>

#include "mrsns/core/tracked_frame.h"

namespace mrsns::io {

enum class SequenceFormat {
  MetaImage,          ///< .mha: header and data in one file
  MetaImageDetached,  ///< .mhd header + ElementDataFile (.raw, or .zraw when compressed)
  Nrrd,               ///< .seq.nrrd: header and data in one file
};

/// "metaimage", "metaimage-detached", "nrrd".
std::string sequenceFormatName(SequenceFormat format);

/// The format a path's extension asks for (.mha, .mhd, .nrrd/.nhdr).
/// Throws UnsupportedError for other extensions.
SequenceFormat sequenceFormatFromPath(const std::filesystem::path& path);

/// Limits that guard against headers claiming absurd sizes.
struct SequenceReadOptions {
  std::uint64_t max_frame_bytes = std::uint64_t{1} << 31;  ///< one frame's pixel data
  std::uint64_t max_total_bytes = std::uint64_t{1} << 36;  ///< all frames' pixel data (decompressed)
  std::uint64_t max_frames = 1'000'000;  // each costs ~200 bytes of metadata before any data is checked
  std::uint64_t max_header_bytes = std::uint64_t{1} << 28;
};

/// How a sequence is stored on disk (what the header says, checked).
struct SequenceStorage {
  SequenceFormat format = SequenceFormat::MetaImage;
  bool compressed = false;
  std::filesystem::path data_file;            ///< the file holding the pixels (the header file itself when inline)
  std::uint64_t data_offset = 0;              ///< where the pixels start in data_file
  std::optional<std::uint64_t> stored_bytes;  ///< CompressedDataSize, or raw size; nullopt when unknown (gzip NRRD)
  bool big_endian = false;
};

struct SequenceWriteOptions {
  bool compress = true;
  int compression_level = 1;  ///< zlib 1..9; 1 is ~5x faster than 6 and within a few % in size on B-mode
  /// Format to write; by default it follows the path's extension.
  std::optional<SequenceFormat> format;
};

/// Reads a sequence frame by frame: the header (every frame's metadata) on
/// open, the pixels of one frame on request. Compressed data is inflated
/// incrementally; reading frames in increasing order never re-inflates,
/// going back restarts from the first frame.
class SequenceReader {
 public:
  explicit SequenceReader(const std::filesystem::path& path, const SequenceReadOptions& options = {});
  ~SequenceReader();
  SequenceReader(SequenceReader&&) noexcept;
  SequenceReader& operator=(SequenceReader&&) noexcept;
  SequenceReader(const SequenceReader&) = delete;
  SequenceReader& operator=(const SequenceReader&) = delete;

  /// Geometry, pixel format, global fields and every frame's metadata; no pixels.
  [[nodiscard]] const TrackedSequence& header() const;
  [[nodiscard]] const SequenceStorage& storage() const;
  [[nodiscard]] std::size_t frameCount() const;
  [[nodiscard]] std::size_t frameBytes() const;

  /// Frame `index` with its pixels. Throws FormatError when the data ends early
  /// or is corrupt, InvalidArgumentError for an index out of range.
  [[nodiscard]] TrackedFrame readFrame(std::size_t index);
  /// The pixels of frame `index` into `out` (frameBytes() long).
  void readFramePixels(std::size_t index, std::span<std::uint8_t> out);

  /// Iteration: the frame after the one last read (frame 0 first), or
  /// nullopt after the last frame.
  [[nodiscard]] std::optional<TrackedFrame> readNextFrame();

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

/// The whole sequence with every frame's pixels.
TrackedSequence readSequence(const std::filesystem::path& path, const SequenceReadOptions& options = {});

/// Header only (every frame's metadata, no pixels): cheap, for summaries.
/// Checks the declared sizes against the file sizes but does not inflate.
TrackedSequence readSequenceHeader(const std::filesystem::path& path, const SequenceReadOptions& options = {},
                                   SequenceStorage* storage = nullptr);

/// Writes `sequence` (every frame must hold its pixels) to a temporary file
/// beside `path`, then renames it over `path`: a failure never leaves a
/// half-written file in its place. For .mhd the data file is NAME.raw/.zraw.
void writeSequence(const std::filesystem::path& path, const TrackedSequence& sequence,
                   const SequenceWriteOptions& options = {});

/// True when `path` holds a MetaImage or NRRD header with per-frame
/// (Seq_Frame...) fields. Never throws; false for unreadable files.
bool looksLikeSequenceFile(const std::filesystem::path& path);

}  // namespace mrsns::io
