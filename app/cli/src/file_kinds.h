#pragma once
// The kinds of file mrsns-cli understands, how a path is recognised, and the
// per-kind summary (`info`) and conversion (`convert`). Each kind lives in its
// own kind_<name>.cpp.
#include <filesystem>
#include <string>

#include "cli_context.h"

namespace mrsns::cli {

enum class FileKind {
  Sequence,   ///< PLUS/Slicer tracked-frame sequences (.igs.mha, .seq.mha, .mha/.mhd with Seq_ fields, .seq.nrrd)
  DeviceSet,  ///< PLUS device-set configuration (.xml)
  Mesh,       ///< triangle meshes (.stl, .vtp, .vtk, .obj, .ply)
  Image,      ///< volumes (.nrrd, .nhdr, .nii, .nii.gz, .mha, .mhd, DICOM file or series folder)
  Landmarks,  ///< Slicer markups (.mrk.json) and legacy .fcsv
  Transform,  ///< ITK/Slicer .tfm/.h5/.mat, 4x4 text matrices (.txt)
  Unknown,
};

/// Name of a kind as printed in reports ("sequence", "mesh", ...).
std::string kindName(FileKind kind);

/// Recognises a file by its name and, where the name is ambiguous (.mha,
/// .mhd, .h5), by its header. Does not validate the content.
FileKind detectFileKind(const std::filesystem::path& path);

/// Options of `convert` shared by all kinds.
struct ConvertOptions {
  bool compress = true;  ///< write compressed data where the format allows
};

// Each returns a report whose json has at least {"file", "kind"} and whose
// text is a readable multi-line summary. They throw mrsns::Error subclasses
// for unreadable input.
Report summarizeSequence(const std::filesystem::path& path);
Report summarizeDeviceSet(const std::filesystem::path& path);
Report summarizeMesh(const std::filesystem::path& path);
Report summarizeImage(const std::filesystem::path& path);
Report summarizeLandmarks(const std::filesystem::path& path);
Report summarizeTransform(const std::filesystem::path& path);

// Convert between formats of one kind; the report says what was written.
Report convertSequence(const std::filesystem::path& in, const std::filesystem::path& out,
                       const ConvertOptions& options);
Report convertMesh(const std::filesystem::path& in, const std::filesystem::path& out, const ConvertOptions& options);
Report convertImage(const std::filesystem::path& in, const std::filesystem::path& out, const ConvertOptions& options);
Report convertLandmarks(const std::filesystem::path& in, const std::filesystem::path& out,
                        const ConvertOptions& options);
Report convertTransform(const std::filesystem::path& in, const std::filesystem::path& out,
                        const ConvertOptions& options);

}  // namespace mrsns::cli
