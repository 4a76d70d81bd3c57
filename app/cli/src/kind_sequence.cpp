// `info` and `convert` for PLUS/Slicer tracked-frame sequences.
#include <algorithm>
#include <cstdio>
#include <set>
#include <sstream>

#include "file_kinds.h"
#include "mrsns/io/sequence_file.h"

namespace mrsns::cli {
namespace {

std::string formatName(const io::SequenceStorage& storage) {
  switch (storage.format) {
    case io::SequenceFormat::MetaImage: return "MetaImage (.mha)";
    case io::SequenceFormat::MetaImageDetached: return "MetaImage with separate data (.mhd)";
    case io::SequenceFormat::Nrrd: return "NRRD (.seq.nrrd)";
  }
  return "unknown";
}

std::string fixed(double value, int digits) {
  char buffer[64];
  std::snprintf(buffer, sizeof buffer, "%.*f", digits, value);
  return buffer;
}

}  // namespace

Report summarizeSequence(const std::filesystem::path& path) {
  io::SequenceStorage storage;
  const TrackedSequence seq = io::readSequenceHeader(path, {}, &storage);
  const auto& g = seq.geometry;
  Report report;
  Json& j = report.json;
  j["file"] = path.string();
  j["kind"] = "sequence";
  j["format"] = io::sequenceFormatName(storage.format);
  j["frames"] = seq.frames.size();
  Json size = Json::array({g.size[0], g.size[1]});
  Json spacing = Json::array({g.spacing[0], g.spacing[1]});
  if (g.dimensions == 3) {
    size.push_back(g.size[2]);
    spacing.push_back(g.spacing[2]);
  }
  j["tracking_only"] = seq.trackingOnly();
  j["image"] = {{"size", size},
                {"pixel_type", pixelTypeName(seq.pixel_format.scalar)},
                {"components", seq.pixel_format.components},
                {"spacing", spacing},
                {"origin", Json::array({g.origin[0], g.origin[1], g.origin[2]})},
                {"orientation", seq.orientation},
                {"frame_bytes", seq.frameBytes()}};
  j["compressed"] = storage.compressed;
  if (storage.stored_bytes) j["stored_bytes"] = *storage.stored_bytes;
  if (storage.data_file != path) j["data_file"] = storage.data_file.string();

  Json transforms = Json::array();
  std::ostringstream transform_text;
  for (const auto& name : seq.transformNames()) {
    std::size_t valid = 0, invalid = 0, missing = 0;
    for (const auto& frame : seq.frames) {
      switch (frame.transformStatus(name)) {
        case TransformStatus::Ok: ++valid; break;
        case TransformStatus::Invalid: ++invalid; break;
        case TransformStatus::Missing: ++missing; break;
      }
    }
    transforms.push_back(
        {{"name", name}, {"valid_frames", valid}, {"invalid_frames", invalid}, {"missing_frames", missing}});
    transform_text << "  " << name << ": " << valid << " valid, " << invalid << " invalid, " << missing << " missing\n";
  }
  j["transforms"] = transforms;

  std::size_t images_ok = 0;
  std::set<std::string> frame_fields;
  for (const auto& frame : seq.frames) {
    if (frame.image_status == "OK") ++images_ok;
    for (const auto& entry : frame.custom_fields) frame_fields.insert(entry.first);
  }
  j["image_status"] = {{"ok", images_ok}, {"not_ok", seq.frames.size() - images_ok}};

  std::string time_text = "  (no frames)\n";
  if (seq.frames.empty()) {
    j["timestamps"] = {{"first", nullptr}, {"last", nullptr}, {"duration_s", 0.0}, {"mean_rate_hz", nullptr}};
  } else {
    const auto [lo, hi] = std::minmax_element(seq.frames.begin(), seq.frames.end(),
                                              [](const auto& a, const auto& b) { return a.timestamp < b.timestamp; });
    const double first = seq.frames.front().timestamp;
    const double last = seq.frames.back().timestamp;
    const double duration = hi->timestamp - lo->timestamp;
    Json rate = nullptr;
    if (duration > 0.0) rate = static_cast<double>(seq.frames.size() - 1) / duration;
    bool increasing = true;
    for (std::size_t i = 1; i < seq.frames.size(); ++i) {
      increasing = increasing && seq.frames[i].timestamp > seq.frames[i - 1].timestamp;
    }
    j["timestamps"] = {{"first", first},
                       {"last", last},
                       {"duration_s", duration},
                       {"mean_rate_hz", rate},
                       {"strictly_increasing", increasing}};
    time_text = "  " + fixed(first, 3) + " s to " + fixed(last, 3) + " s (" + fixed(duration, 3) + " s" +
                (rate.is_null() ? std::string() : ", " + fixed(rate.get<double>(), 2) + " Hz") + ")" +
                (increasing ? "" : ", NOT strictly increasing") + "\n";
  }

  Json custom = Json::array();
  for (const auto& [key, value] : seq.custom_header_fields) custom.push_back({{"name", key}, {"value", value}});
  j["custom_fields"] = custom;
  j["frame_fields"] = Json(std::vector<std::string>(frame_fields.begin(), frame_fields.end()));

  std::ostringstream text;
  text << path.string() << ": tracked-frame sequence, " << formatName(storage)
       << (storage.compressed ? ", zlib-compressed" : ", uncompressed") << "\n";
  if (seq.trackingOnly()) {
    text << "Frames: " << seq.frames.size() << ", no images (a tracker buffer)\n";
  } else {
    text << "Frames: " << seq.frames.size() << " of " << g.size[0] << "x" << g.size[1];
    if (g.dimensions == 3) text << "x" << g.size[2];
    text << " " << pixelTypeName(seq.pixel_format.scalar);
    if (seq.pixel_format.components > 1) text << " x" << seq.pixel_format.components;
    text << ", spacing " << g.spacing[0] << " x " << g.spacing[1] << ", orientation " << seq.orientation << "\n";
  }
  text << "Images OK: " << images_ok << " of " << seq.frames.size() << "\n";
  text << "Time:\n" << time_text;
  text << "Transforms:\n" << (transforms.empty() ? "  (none)\n" : transform_text.str());
  if (!seq.custom_header_fields.empty()) {
    text << "Header fields:\n";
    for (const auto& [key, value] : seq.custom_header_fields) text << "  " << key << " = " << value << "\n";
  }
  if (!frame_fields.empty()) {
    text << "Per-frame fields:";
    for (const auto& name : frame_fields) text << " " << name;
    text << "\n";
  }
  report.text = text.str();
  return report;
}

Report convertSequence(const std::filesystem::path& in, const std::filesystem::path& out,
                       const ConvertOptions& options) {
  const io::SequenceFormat format = io::sequenceFormatFromPath(out);
  const TrackedSequence seq = io::readSequence(in);
  io::SequenceWriteOptions write_options;
  write_options.compress = options.compress;
  write_options.format = format;
  io::writeSequence(out, seq, write_options);
  std::error_code ec;
  const auto bytes = std::filesystem::file_size(out, ec);
  Report report;
  report.json = {{"file", out.string()},        {"input", in.string()},
                 {"kind", "sequence"},          {"format", io::sequenceFormatName(format)},
                 {"frames", seq.frames.size()}, {"compressed", options.compress},
                 {"bytes", ec ? 0 : bytes}};
  report.text = "Wrote " + std::to_string(seq.frames.size()) + " frames to " + out.string() + " (" +
                io::sequenceFormatName(format) + (options.compress ? ", compressed" : ", uncompressed") + ")";
  return report;
}

}  // namespace mrsns::cli
