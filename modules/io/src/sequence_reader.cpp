// Reading sequence files: the header, then the pixels frame by frame. The
// declared sizes are checked against the bytes actually on disk before any
// allocation; zlib/gzip data is inflated incrementally.
// GCC 12 reports a false -Wrestrict on "literal" + std::string at -O3 (GCC bug 105651).
#if defined(__GNUC__) && !defined(__clang__)
#pragma GCC diagnostic ignored "-Wrestrict"
#endif
#include <zlib.h>

#include <algorithm>
#include <cstdio>
#include <cstring>
#include <fstream>

#include "mrsns/core/error.h"
#include "mrsns/core/log.h"
#include "sequence_internal.h"

namespace mrsns::io {
namespace {

// deflate cannot compress better than about 1032:1, so more declared pixel
// bytes than this per stored byte means the header lies.
constexpr std::uint64_t kMaxDeflateRatio = 1032;
constexpr std::size_t kChunk = 1 << 18;

struct OpenedHeader {
  detail::ParsedHeader parsed;
  SequenceStorage storage;
};

std::uint64_t fileSize(const std::filesystem::path& path, const std::string& what) {
  std::error_code ec;
  const auto size = std::filesystem::file_size(path, ec);
  if (ec) throw FileError("cannot read " + what + " '" + path.string() + "': " + ec.message());
  return size;
}

OpenedHeader openHeader(const std::filesystem::path& path, const SequenceReadOptions& options) {
  const std::string source = path.string();
  const std::uint64_t size = fileSize(path, "sequence file");
  std::ifstream in(path, std::ios::binary);
  if (!in) throw FileError("cannot open sequence file '" + source + "': check the path and permissions");
  std::string text;
  std::optional<std::size_t> end;
  while (!end) {
    const std::size_t old = text.size();
    // Small files (and fuzz inputs) need not pay for a full chunk.
    const std::size_t chunk = static_cast<std::size_t>(std::min<std::uint64_t>(kChunk, size > old ? size - old : 1));
    text.resize(old + chunk);
    in.read(text.data() + old, static_cast<std::streamsize>(chunk));
    text.resize(old + static_cast<std::size_t>(in.gcount()));
    const bool at_end = text.size() >= size || in.gcount() == 0;
    end = detail::isNrrdText(text) ? detail::findNrrdHeaderEnd(text, at_end)
                                   : detail::findMetaImageHeaderEnd(text, at_end);
    if (end) break;
    if (at_end) {
      throw FormatError("'" + source +
                        "' has no complete header: no 'ElementDataFile' line (MetaImage) or blank line (NRRD) was "
                        "found; the file is truncated or not a sequence file");
    }
    if (text.size() > options.max_header_bytes) {
      throw FormatError("'" + source + "': no end of header in the first " + std::to_string(options.max_header_bytes) +
                        " bytes; not a sequence file (or raise SequenceReadOptions::max_header_bytes)");
    }
  }
  const std::string_view header(text.data(), *end);
  OpenedHeader opened{detail::isNrrdText(header) ? detail::parseNrrdHeader(header, source, options)
                                                 : detail::parseMetaImageHeader(header, source, options),
                      {}};
  auto& parsed = opened.parsed;
  SequenceStorage& storage = opened.storage;
  storage = parsed.storage;
  const std::string& name = parsed.storage.data_file.string();
  if (name == "LOCAL") {
    storage.data_file = path;
  } else {
    storage.data_file = path.parent_path() / name;
    std::error_code ec;
    if (!std::filesystem::is_regular_file(storage.data_file, ec)) {
      throw FileError("'" + source + "' names the data file '" + name + "', which does not exist beside it (" +
                      storage.data_file.string() + ")");
    }
  }
  storage.data_offset = parsed.header_bytes;
  const std::uint64_t data_size = storage.data_file == path ? size : fileSize(storage.data_file, "data file");
  if (storage.data_offset > data_size) {
    throw FormatError("'" + source + "': the data should start at byte " + std::to_string(storage.data_offset) +
                      " but '" + storage.data_file.string() + "' has only " + std::to_string(data_size) + " bytes");
  }
  const std::uint64_t available = data_size - storage.data_offset;
  const std::uint64_t total = parsed.sequence.frameBytes() * parsed.frame_count;  // bounded by checkDeclaredSizes
  if (storage.compressed) {
    if (storage.stored_bytes && *storage.stored_bytes > available) {
      throw FormatError("'" + source + "': CompressedDataSize is " + std::to_string(*storage.stored_bytes) +
                        " bytes but only " + std::to_string(available) +
                        " bytes of data are present: the file is truncated");
    }
    const std::uint64_t stored = storage.stored_bytes.value_or(available);
    storage.stored_bytes = stored;
    if (total > stored * kMaxDeflateRatio + 1024) {
      throw FormatError("'" + source + "': the header declares " + std::to_string(parsed.frame_count) + " frames (" +
                        std::to_string(total) + " bytes) but " + std::to_string(stored) +
                        " compressed bytes cannot hold that much: the frame count or image size is wrong");
    }
  } else {
    if (total > available) {
      throw FormatError("'" + source + "': the header declares " + std::to_string(parsed.frame_count) + " frames of " +
                        std::to_string(parsed.sequence.frameBytes()) + " bytes (" + std::to_string(total) +
                        " bytes) but only " + std::to_string(available) +
                        " bytes of data are present: the file is truncated or DimSize/sizes is wrong");
    }
    storage.stored_bytes = total;
  }
  return opened;
}

void swapBytes(std::span<std::uint8_t> data, std::size_t element) {
  for (std::size_t i = 0; i + element <= data.size(); i += element)
    std::reverse(data.begin() + static_cast<std::ptrdiff_t>(i),
                 data.begin() + static_cast<std::ptrdiff_t>(i + element));
}

}  // namespace

struct SequenceReader::Impl {
  std::string source;
  SequenceReadOptions options;
  TrackedSequence header;
  SequenceStorage storage;
  std::size_t frame_bytes = 0;
  std::size_t cursor = 0;  // the frame readNextFrame() returns
  std::ifstream data;
  // Inflate state: the stream has produced every frame before `next_frame`.
  z_stream zs{};
  bool z_ready = false;
  std::size_t next_frame = 0;
  std::uint64_t consumed = 0;  // compressed bytes handed to zlib so far
  std::vector<std::uint8_t> in_buffer;
  std::vector<std::uint8_t> skip_buffer;

  ~Impl() {
    if (z_ready) inflateEnd(&zs);
  }

  [[noreturn]] void failData(std::size_t index, const std::string& what) const {
    throw FormatError("'" + source + "': cannot read frame " + std::to_string(index) + " of " +
                      std::to_string(header.frames.size()) + ": " + what);
  }

  void restartInflate() {
    if (!z_ready) {
      if (inflateInit2(&zs, 15 + 32) != Z_OK)
        throw ComputationError("zlib could not be initialised");  // auto-detect zlib/gzip
      z_ready = true;
      in_buffer.resize(
          static_cast<std::size_t>(std::min<std::uint64_t>(kChunk, std::max<std::uint64_t>(*storage.stored_bytes, 1))));
    } else {
      inflateReset(&zs);
    }
    zs.next_in = nullptr;
    zs.avail_in = 0;
    consumed = 0;
    next_frame = 0;
    data.clear();
    data.seekg(static_cast<std::streamoff>(storage.data_offset));
  }

  // zlib counts in 32 bits: inflate frames larger than that in pieces.
  void inflateInto(std::size_t index, std::span<std::uint8_t> out) {
    constexpr std::size_t kMaxPiece = std::size_t{1} << 30;
    while (!out.empty()) {
      const auto piece = out.first(std::min(out.size(), kMaxPiece));
      inflatePiece(index, piece);
      out = out.subspan(piece.size());
    }
  }

  void inflatePiece(std::size_t index, std::span<std::uint8_t> out) {
    zs.next_out = out.data();
    zs.avail_out = static_cast<uInt>(out.size());
    while (zs.avail_out > 0) {
      if (zs.avail_in == 0) {
        const std::uint64_t left = *storage.stored_bytes - consumed;
        const std::size_t want = static_cast<std::size_t>(std::min<std::uint64_t>(left, in_buffer.size()));
        if (want == 0)
          failData(index,
                   "the compressed data ends early (file truncated, or the header declares more frames than it holds)");
        data.read(reinterpret_cast<char*>(in_buffer.data()), static_cast<std::streamsize>(want));
        const auto got = static_cast<std::size_t>(data.gcount());
        if (got == 0) failData(index, "the file ends inside the compressed data (truncated)");
        consumed += got;
        zs.next_in = in_buffer.data();
        zs.avail_in = static_cast<uInt>(got);
      }
      const int ret = inflate(&zs, Z_NO_FLUSH);
      if (ret == Z_STREAM_END && zs.avail_out > 0) {
        failData(index,
                 "the compressed stream ends before this frame is complete: the header declares more frames "
                 "than the data holds");
      }
      if (ret == Z_DATA_ERROR || ret == Z_NEED_DICT) {
        failData(index, std::string("corrupt compressed data (zlib: ") + (zs.msg ? zs.msg : "data error") + ")");
      }
      if (ret == Z_MEM_ERROR) throw std::bad_alloc();
      if (ret == Z_STREAM_END) break;
    }
  }

  // After the last frame, run the stream to its end so zlib verifies its
  // checksum: corruption that still inflates is caught here.
  void finishStream(std::size_t index) {
    std::uint8_t sink[4096];
    while (true) {
      zs.next_out = sink;
      zs.avail_out = sizeof sink;
      if (zs.avail_in == 0) {
        const std::uint64_t left = *storage.stored_bytes - consumed;
        const std::size_t want = static_cast<std::size_t>(std::min<std::uint64_t>(left, in_buffer.size()));
        if (want == 0) return;  // no trailer to check (data ends exactly after the pixels)
        data.read(reinterpret_cast<char*>(in_buffer.data()), static_cast<std::streamsize>(want));
        const auto got = static_cast<std::size_t>(data.gcount());
        if (got == 0) return;
        consumed += got;
        zs.next_in = in_buffer.data();
        zs.avail_in = static_cast<uInt>(got);
      }
      const int ret = inflate(&zs, Z_NO_FLUSH);
      if (ret == Z_STREAM_END) return;
      if (ret == Z_DATA_ERROR || ret == Z_NEED_DICT) {
        failData(index, std::string("corrupt compressed data (zlib: ") + (zs.msg ? zs.msg : "data error") + ")");
      }
      if (zs.avail_out == 0) {
        logger()->warn("'{}': compressed data holds more than the {} frames the header declares; ignoring the rest",
                       source, header.frames.size());
        return;
      }
    }
  }

  void read(std::size_t index, std::span<std::uint8_t> out) {
    if (index >= header.frames.size()) {
      throw InvalidArgumentError("frame " + std::to_string(index) + " requested from '" + source + "', which has " +
                                 std::to_string(header.frames.size()) + " frames");
    }
    if (out.size() != frame_bytes) {
      throw InvalidArgumentError("frame buffer of " + std::to_string(out.size()) + " bytes for '" + source +
                                 "', whose frames have " + std::to_string(frame_bytes) + " bytes");
    }
    if (frame_bytes == 0) return;  // a tracker buffer: no pixels to read
    if (storage.compressed) {
      if (!z_ready || index < next_frame) restartInflate();
      if (next_frame < index) skip_buffer.resize(frame_bytes);
      while (next_frame < index) {
        inflateInto(next_frame, skip_buffer);
        ++next_frame;
      }
      inflateInto(index, out);
      next_frame = index + 1;
      if (next_frame == header.frames.size()) finishStream(index);
    } else {
      data.clear();
      data.seekg(static_cast<std::streamoff>(storage.data_offset + static_cast<std::uint64_t>(index) * frame_bytes));
      data.read(reinterpret_cast<char*>(out.data()), static_cast<std::streamsize>(out.size()));
      if (static_cast<std::size_t>(data.gcount()) != out.size()) failData(index, "the file ends early (truncated)");
    }
    const std::size_t element = pixelTypeSize(header.pixel_format.scalar);
    if (storage.big_endian && element > 1) swapBytes(out, element);
  }
};

SequenceReader::SequenceReader(const std::filesystem::path& path, const SequenceReadOptions& options)
    : impl_(std::make_unique<Impl>()) {
  auto opened = openHeader(path, options);
  impl_->source = path.string();
  impl_->options = options;
  impl_->header = std::move(opened.parsed.sequence);
  impl_->storage = std::move(opened.storage);
  impl_->frame_bytes = impl_->header.frameBytes();
  impl_->data.open(impl_->storage.data_file, std::ios::binary);
  if (!impl_->data) throw FileError("cannot open data file '" + impl_->storage.data_file.string() + "'");
}

SequenceReader::~SequenceReader() = default;
SequenceReader::SequenceReader(SequenceReader&&) noexcept = default;
SequenceReader& SequenceReader::operator=(SequenceReader&&) noexcept = default;

const TrackedSequence& SequenceReader::header() const {
  return impl_->header;
}
const SequenceStorage& SequenceReader::storage() const {
  return impl_->storage;
}
std::size_t SequenceReader::frameCount() const {
  return impl_->header.frames.size();
}
std::size_t SequenceReader::frameBytes() const {
  return impl_->frame_bytes;
}

TrackedFrame SequenceReader::readFrame(std::size_t index) {
  if (index >= frameCount()) impl_->read(index, {});  // throws the out-of-range error
  TrackedFrame frame = impl_->header.frames[index];
  frame.pixels.resize(impl_->frame_bytes);
  impl_->read(index, frame.pixels);
  impl_->cursor = index + 1;
  return frame;
}

void SequenceReader::readFramePixels(std::size_t index, std::span<std::uint8_t> out) {
  impl_->read(index, out);
  impl_->cursor = index + 1;
}

std::optional<TrackedFrame> SequenceReader::readNextFrame() {
  if (impl_->cursor >= frameCount()) return std::nullopt;
  return readFrame(impl_->cursor);
}

TrackedSequence readSequence(const std::filesystem::path& path, const SequenceReadOptions& options) {
  SequenceReader reader(path, options);
  TrackedSequence sequence = reader.header();
  for (std::size_t i = 0; i < sequence.frames.size(); ++i) {
    sequence.frames[i].pixels.resize(reader.frameBytes());
    reader.readFramePixels(i, sequence.frames[i].pixels);
  }
  return sequence;
}

TrackedSequence readSequenceHeader(const std::filesystem::path& path, const SequenceReadOptions& options,
                                   SequenceStorage* storage) {
  auto opened = openHeader(path, options);
  if (storage) *storage = opened.storage;
  return std::move(opened.parsed.sequence);
}

bool looksLikeSequenceFile(const std::filesystem::path& path) {
  try {
    std::ifstream in(path, std::ios::binary);
    if (!in) return false;
    std::string text(1 << 16, '\0');
    in.read(text.data(), static_cast<std::streamsize>(text.size()));
    text.resize(static_cast<std::size_t>(in.gcount()));
    const bool at_end = in.eof();
    const auto end = detail::isNrrdText(text) ? detail::findNrrdHeaderEnd(text, at_end)
                                              : detail::findMetaImageHeaderEnd(text, at_end);
    const std::string_view header(text.data(), end.value_or(text.size()));
    return header.find("\nSeq_Frame") != std::string_view::npos;
  } catch (const std::exception&) {
    return false;
  }
}

std::string sequenceFormatName(SequenceFormat format) {
  switch (format) {
    case SequenceFormat::MetaImage: return "metaimage";
    case SequenceFormat::MetaImageDetached: return "metaimage-detached";
    case SequenceFormat::Nrrd: return "nrrd";
  }
  return "unknown";
}

SequenceFormat sequenceFormatFromPath(const std::filesystem::path& path) {
  std::string ext = path.extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  if (ext == ".mha") return SequenceFormat::MetaImage;
  if (ext == ".mhd") return SequenceFormat::MetaImageDetached;
  if (ext == ".nrrd") return SequenceFormat::Nrrd;
  throw UnsupportedError("'" + path.string() +
                         "': unknown sequence extension; use .igs.mha/.seq.mha/.mha, .mhd (+ .raw/.zraw) or .seq.nrrd");
}

}  // namespace mrsns::io
