// `mrsns-cli info FILE`: a summary of any supported file.
#include <filesystem>

#include "cli_context.h"
#include "file_kinds.h"
#include "mrsns/core/error.h"

namespace mrsns::cli {

void addJsonFlag(CLI::App& sub, GlobalOptions& options) {
  sub.add_flag("--json", options.json, "print one JSON object with the results instead of text");
}

void registerInfoVerb(CLI::App& app, GlobalOptions& options, VerbList& verbs) {
  auto* sub = app.add_subcommand(
      "info",
      "Summarise a file: sequences (frames, image size, transforms and how many frames have each valid, time "
      "range), device sets, meshes, images (size, spacing, origin, direction, labels), landmarks, transforms");
  auto file = std::make_shared<std::string>();
  sub->add_option("FILE", *file, "file (or DICOM series folder) to summarise")->required();
  addJsonFlag(*sub, options);
  verbs.emplace_back(sub, [file]() -> Report {
    const std::filesystem::path path(*file);
    std::error_code ec;
    if (!std::filesystem::exists(path, ec)) {
      throw FileError("'" + path.string() + "' does not exist: check the path");
    }
    switch (detectFileKind(path)) {
      case FileKind::Sequence: return summarizeSequence(path);
      case FileKind::DeviceSet: return summarizeDeviceSet(path);
      case FileKind::Mesh: return summarizeMesh(path);
      case FileKind::Image: return summarizeImage(path);
      case FileKind::Landmarks: return summarizeLandmarks(path);
      case FileKind::Transform: return summarizeTransform(path);
      case FileKind::Unknown: break;
    }
    throw UnsupportedError("'" + path.string() +
                           "' is not a file kind mrsns-cli knows (sequences .igs.mha/.seq.mha/.seq.nrrd, device sets "
                           ".xml, meshes .stl/.vtp/.vtk/.obj/.ply, images .nrrd/.nii/.mha/.mhd/DICOM, landmarks "
                           ".mrk.json/.fcsv, transforms .tfm/.h5/.txt)");
  });
}

void registerConvertVerb(CLI::App& app, GlobalOptions& options, VerbList& verbs) {
  auto* sub = app.add_subcommand("convert",
                                 "Convert a file to another format of the same kind; the output format follows from "
                                 "OUT's extension (e.g. .igs.mha -> .seq.nrrd, .stl -> .vtp, DICOM -> .nrrd, .fcsv -> "
                                 ".mrk.json, .tfm -> .h5)");
  auto in = std::make_shared<std::string>();
  auto out = std::make_shared<std::string>();
  auto convert_options = std::make_shared<ConvertOptions>();
  sub->add_option("IN", *in, "input file (or DICOM series folder)")->required();
  sub->add_option("OUT", *out, "output file")->required();
  sub->add_flag("!--no-compress", convert_options->compress, "write uncompressed data where the format allows");
  addJsonFlag(*sub, options);
  verbs.emplace_back(sub, [in, out, convert_options]() -> Report {
    const std::filesystem::path in_path(*in);
    const std::filesystem::path out_path(*out);
    std::error_code ec;
    if (!std::filesystem::exists(in_path, ec)) {
      throw FileError("'" + in_path.string() + "' does not exist: check the path");
    }
    const FileKind in_kind = detectFileKind(in_path);
    FileKind out_kind = detectFileKind(out_path);
    // A new .mha/.mhd output cannot be sniffed: it takes the input's kind.
    if ((in_kind == FileKind::Sequence || in_kind == FileKind::Image) &&
        (out_kind == FileKind::Sequence || out_kind == FileKind::Image)) {
      const auto ext = out_path.extension().string();
      if (ext == ".mha" || ext == ".mhd") out_kind = in_kind;
    }
    if (in_kind != out_kind || in_kind == FileKind::Unknown || in_kind == FileKind::DeviceSet) {
      throw UnsupportedError("cannot convert '" + in_path.string() + "' (" + kindName(in_kind) + ") to '" +
                             out_path.string() + "' (" + kindName(out_kind) +
                             "): convert only between formats of one kind (sequence, mesh, image, landmarks, "
                             "transform)");
    }
    switch (in_kind) {
      case FileKind::Sequence: return convertSequence(in_path, out_path, *convert_options);
      case FileKind::Mesh: return convertMesh(in_path, out_path, *convert_options);
      case FileKind::Image: return convertImage(in_path, out_path, *convert_options);
      case FileKind::Landmarks: return convertLandmarks(in_path, out_path, *convert_options);
      case FileKind::Transform: return convertTransform(in_path, out_path, *convert_options);
      default: break;
    }
    throw UnsupportedError("cannot convert " + kindName(in_kind) + " files");
  });
}

}  // namespace mrsns::cli
