// Writing sequence files. Everything goes to a temporary file beside the
// target and is renamed over it only when complete, so a failed write never
// destroys an existing recording.
// GCC 12 reports a false -Wrestrict on "literal" + std::string at -O3 (GCC bug 105651).
#if defined(__GNUC__) && !defined(__clang__)
#pragma GCC diagnostic ignored "-Wrestrict"
#endif
#include <unistd.h>
#include <zlib.h>

#include <atomic>
#include <cstdio>
#include <fstream>

#include "mrsns/core/error.h"
#include "mrsns/core/log.h"
#include "sequence_internal.h"

namespace mrsns::io {
namespace {

std::filesystem::path temporaryBeside(const std::filesystem::path& target) {
  static std::atomic<unsigned> counter{0};
  const auto dir = target.has_parent_path() ? target.parent_path() : std::filesystem::path(".");
  return dir /
         ("." + target.filename().string() + ".tmp" + std::to_string(::getpid()) + "_" + std::to_string(counter++));
}

// A file written under a temporary name; removed unless commit() renamed it.
class TempFile {
 public:
  explicit TempFile(std::filesystem::path target) : target_(std::move(target)), temp_(temporaryBeside(target_)) {
    out_.open(temp_, std::ios::binary | std::ios::trunc);
    if (!out_) {
      throw FileError("cannot write '" + target_.string() + "': cannot create a file in '" +
                      temp_.parent_path().string() + "' (does the folder exist, is it writable?)");
    }
  }
  ~TempFile() {
    if (!committed_) {
      out_.close();
      std::error_code ec;
      std::filesystem::remove(temp_, ec);
    }
  }
  TempFile(const TempFile&) = delete;
  TempFile& operator=(const TempFile&) = delete;

  std::ofstream& stream() { return out_; }

  void write(const void* data, std::size_t size) {
    out_.write(static_cast<const char*>(data), static_cast<std::streamsize>(size));
    check();
  }
  void check() {
    if (!out_) throw FileError("writing '" + target_.string() + "' failed (disk full?); the original is untouched");
  }
  void close() {
    out_.flush();
    check();
    out_.close();
    if (out_.fail()) throw FileError("closing '" + target_.string() + "' failed (disk full?)");
  }
  void commit() {
    std::error_code ec;
    std::filesystem::rename(temp_, target_, ec);
    if (ec) throw FileError("cannot replace '" + target_.string() + "': " + ec.message());
    committed_ = true;
  }

 private:
  std::filesystem::path target_;
  std::filesystem::path temp_;
  std::ofstream out_;
  bool committed_ = false;
};

// Writes all frames' pixels, deflated (zlib or gzip wrapper) or raw; returns the bytes written.
std::uint64_t writePixels(TempFile& file, const TrackedSequence& sequence, bool compress, int level, bool gzip) {
  if (!compress) {
    std::uint64_t written = 0;
    for (const auto& frame : sequence.frames) {
      file.write(frame.pixels.data(), frame.pixels.size());
      written += frame.pixels.size();
    }
    return written;
  }
  z_stream zs{};
  if (deflateInit2(&zs, level, Z_DEFLATED, gzip ? 15 + 16 : 15, 8, Z_DEFAULT_STRATEGY) != Z_OK) {
    throw InvalidArgumentError("zlib refused compression level " + std::to_string(level) + " (use 1..9)");
  }
  std::vector<std::uint8_t> out(1 << 18);
  std::uint64_t written = 0;
  try {
    const auto pump = [&](int flush) {
      int ret = Z_OK;
      do {
        zs.next_out = out.data();
        zs.avail_out = static_cast<uInt>(out.size());
        ret = deflate(&zs, flush);
        if (ret == Z_STREAM_ERROR) throw ComputationError("zlib deflate failed");
        const std::size_t have = out.size() - zs.avail_out;
        file.write(out.data(), have);
        written += have;
      } while (zs.avail_out == 0 || (flush == Z_FINISH && ret != Z_STREAM_END));
    };
    for (const auto& frame : sequence.frames) {
      // Feed at most 1 GiB at a time: avail_in is 32-bit.
      std::size_t offset = 0;
      while (offset < frame.pixels.size()) {
        const std::size_t n = std::min<std::size_t>(frame.pixels.size() - offset, std::size_t{1} << 30);
        zs.next_in = const_cast<Bytef*>(frame.pixels.data() + offset);
        zs.avail_in = static_cast<uInt>(n);
        pump(Z_NO_FLUSH);
        offset += n;
      }
    }
    zs.next_in = nullptr;
    zs.avail_in = 0;
    pump(Z_FINISH);
  } catch (...) {
    deflateEnd(&zs);
    throw;
  }
  deflateEnd(&zs);
  return written;
}

void writeMetaImage(const std::filesystem::path& path, const TrackedSequence& sequence,
                    const SequenceWriteOptions& options) {
  TempFile file(path);
  std::size_t size_offset = 0;
  const std::string header =
      detail::formatMetaImageHeader(sequence, options.compress, std::nullopt, "LOCAL", &size_offset);
  file.write(header.data(), header.size());
  const std::uint64_t stored = writePixels(file, sequence, options.compress, options.compression_level, false);
  if (options.compress) {
    // The size is known only now: overwrite the padded placeholder in place.
    const std::string size = std::to_string(stored);
    file.stream().seekp(static_cast<std::streamoff>(size_offset));
    file.write(size.data(), size.size());
  }
  file.close();
  file.commit();
}

void writeMetaImageDetached(const std::filesystem::path& path, const TrackedSequence& sequence,
                            const SequenceWriteOptions& options) {
  std::filesystem::path data_path = path;
  data_path.replace_extension(options.compress ? ".zraw" : ".raw");
  TempFile data(data_path);
  const std::uint64_t stored = writePixels(data, sequence, options.compress, options.compression_level, false);
  data.close();
  TempFile file(path);
  const std::string header =
      detail::formatMetaImageHeader(sequence, options.compress, stored, data_path.filename().string(), nullptr);
  file.write(header.data(), header.size());
  file.close();
  data.commit();
  file.commit();
}

void writeNrrd(const std::filesystem::path& path, const TrackedSequence& sequence,
               const SequenceWriteOptions& options) {
  TempFile file(path);
  const std::string header = detail::formatNrrdHeader(sequence, options.compress);
  file.write(header.data(), header.size());
  writePixels(file, sequence, options.compress, options.compression_level, true);
  file.close();
  file.commit();
}

}  // namespace

void writeSequence(const std::filesystem::path& path, const TrackedSequence& sequence,
                   const SequenceWriteOptions& options) {
  const SequenceFormat format = options.format ? *options.format : sequenceFormatFromPath(path);
  detail::checkWritable(sequence, path.string());
  if (format == SequenceFormat::Nrrd && sequence.trackingOnly()) {
    throw InvalidArgumentError("cannot write sequence to '" + path.string() +
                               "': it has no images (a tracker buffer), which NRRD cannot hold (its sizes must be "
                               "positive); write it as .mha or .mhd");
  }
  if (options.compress && (options.compression_level < 1 || options.compression_level > 9)) {
    throw InvalidArgumentError("compression level " + std::to_string(options.compression_level) + " for '" +
                               path.string() + "' is outside 1..9");
  }
  switch (format) {
    case SequenceFormat::MetaImage: writeMetaImage(path, sequence, options); break;
    case SequenceFormat::MetaImageDetached: writeMetaImageDetached(path, sequence, options); break;
    case SequenceFormat::Nrrd: writeNrrd(path, sequence, options); break;
  }
  logger()->debug("wrote {} frames to '{}'", sequence.frames.size(), path.string());
}

}  // namespace mrsns::io
