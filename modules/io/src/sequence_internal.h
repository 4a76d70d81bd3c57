#pragma once
// Private pieces of the sequence-file readers and writers, shared by the
// MetaImage and NRRD flavours and by the fuzz target (which compiles the
// header parsers alone, without the file layer).
#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "mrsns/core/tracked_frame.h"
#include "mrsns/io/sequence_file.h"

namespace mrsns::io::detail {

/// A header parsed from text: the sequence without pixels and where the data is.
struct ParsedHeader {
  TrackedSequence sequence;
  SequenceStorage storage;  ///< data_file holds the name as written ("LOCAL" for inline data)
  std::uint64_t frame_count = 0;
  std::uint64_t header_bytes = 0;  ///< length of the header text, i.e. offset of inline data
};

/// End of a MetaImage header in `text` (the offset just after the
/// ElementDataFile line), or nullopt when `text` does not hold all of it yet.
/// `at_end`: `text` is the whole file, so its end also ends the last line.
std::optional<std::size_t> findMetaImageHeaderEnd(std::string_view text, bool at_end);
/// End of a NRRD header (just after the first empty line), or nullopt; with
/// `at_end` a header without data (detached .nhdr) ends with the text.
std::optional<std::size_t> findNrrdHeaderEnd(std::string_view text, bool at_end);

/// Parses a complete header. `source` names the file in error messages.
/// Throws FormatError / UnsupportedError; never allocates by a declared size.
ParsedHeader parseMetaImageHeader(std::string_view text, const std::string& source, const SequenceReadOptions& options);
ParsedHeader parseNrrdHeader(std::string_view text, const std::string& source, const SequenceReadOptions& options);

/// True when `text` starts like a NRRD file ("NRRD000").
bool isNrrdText(std::string_view text);

/// Header text for `sequence`. For compressed MetaImage data whose size is
/// not known yet, pass `compressed_size` nullopt: the field is padded so the
/// size can be written over it afterwards at `*size_field_offset`.
std::string formatMetaImageHeader(const TrackedSequence& sequence, bool compressed,
                                  std::optional<std::uint64_t> compressed_size, const std::string& data_file,
                                  std::size_t* size_field_offset);
std::string formatNrrdHeader(const TrackedSequence& sequence, bool compressed);

/// Width of the padded CompressedDataSize value.
inline constexpr std::size_t kCompressedSizeFieldWidth = 20;

// ---- shared text helpers (sequence_text.cpp) ----

std::string_view trim(std::string_view s);
bool iequals(std::string_view a, std::string_view b);
bool startsWith(std::string_view s, std::string_view prefix);
bool endsWith(std::string_view s, std::string_view suffix);
std::vector<std::string_view> splitWhitespace(std::string_view s);
std::optional<double> parseDouble(std::string_view s);
std::optional<std::int64_t> parseInt(std::string_view s);
/// Shortest text that reads back to exactly `value`.
std::string formatDouble(double value);

/// Per-frame fields collected while parsing, applied once the frame count is known.
struct FrameField {
  std::uint64_t frame = 0;
  std::string name;  ///< the part after "Seq_FrameNNNN_"
  std::string value;
  std::size_t line = 0;
};

/// Splits "Seq_Frame0012_ProbeToTrackerTransform" into {12, "ProbeToTrackerTransform"};
/// nullopt when `key` is not a per-frame key. Throws FormatError for a
/// malformed one ("Seq_FrameXY_...").
std::optional<std::pair<std::uint64_t, std::string>> splitFrameKey(std::string_view key, const std::string& source,
                                                                   std::size_t line);

/// Applies collected per-frame fields to `sequence.frames` (sized already).
/// `has_timestamp`, when given, is set per frame that had a Timestamp field.
void applyFrameFields(TrackedSequence& sequence, const std::vector<FrameField>& fields, const std::string& source,
                      std::vector<bool>* has_timestamp);

/// Calls `emit(name, value)` for every per-frame field of `frame` (name without the Seq_Frame prefix).
void forEachFrameField(const TrackedFrame& frame,
                       const std::function<void(const std::string&, const std::string&)>& emit);

/// "Seq_Frame0012_" with at least 4 digits, more when `frame_count` needs them.
std::string frameKeyPrefix(std::size_t index, std::size_t frame_count);

/// Checks the declared sizes against the limits; throws FormatError naming `source`.
void checkDeclaredSizes(const TrackedSequence& sequence, std::uint64_t frame_count, const std::string& source,
                        const SequenceReadOptions& options);

/// Throws InvalidArgumentError when `sequence` cannot be written to `target`
/// (frames without pixels of frameBytes(), field names or values that would
/// break a header line or collide with the layout fields).
void checkWritable(const TrackedSequence& sequence, const std::string& target);

/// Fields a writer generates itself (geometry, encoding); a custom field may not use these names.
bool isMetaImageStructuralField(std::string_view key);
bool isNrrdStructuralField(std::string_view key);

}  // namespace mrsns::io::detail
