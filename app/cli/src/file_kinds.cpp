#include "file_kinds.h"

#include <algorithm>
#include <cctype>
#include <fstream>

#include "mrsns/io/file_names.h"
#include "mrsns/io/sequence_file.h"

namespace mrsns::cli {
using io::endsWith;

std::string kindName(FileKind kind) {
  switch (kind) {
    case FileKind::Sequence: return "sequence";
    case FileKind::DeviceSet: return "device-set";
    case FileKind::Mesh: return "mesh";
    case FileKind::Image: return "image";
    case FileKind::Landmarks: return "landmarks";
    case FileKind::Transform: return "transform";
    case FileKind::Unknown: break;
  }
  return "unknown";
}

FileKind detectFileKind(const std::filesystem::path& path) {
  std::error_code ec;
  if (std::filesystem::is_directory(path, ec)) return FileKind::Image;  // a DICOM series folder
  const std::string name = io::lowerFileName(path);
  if (endsWith(name, ".seq.nrrd") || endsWith(name, ".seq.nhdr") || endsWith(name, ".igs.mha") ||
      endsWith(name, ".igs.mhd") || endsWith(name, ".seq.mha") || endsWith(name, ".seq.mhd")) {
    return FileKind::Sequence;
  }
  if (endsWith(name, ".mha") || endsWith(name, ".mhd")) {
    // The same extension holds both: a tracked sequence has per-frame fields.
    return io::looksLikeSequenceFile(path) ? FileKind::Sequence : FileKind::Image;
  }
  if (endsWith(name, ".mrk.json") || endsWith(name, ".fcsv")) return FileKind::Landmarks;
  if (endsWith(name, ".xml")) return FileKind::DeviceSet;
  if (endsWith(name, ".stl") || endsWith(name, ".vtp") || endsWith(name, ".vtk") || endsWith(name, ".obj") ||
      endsWith(name, ".ply")) {
    return FileKind::Mesh;
  }
  if (endsWith(name, ".nrrd") || endsWith(name, ".nhdr") || endsWith(name, ".nii") || endsWith(name, ".nii.gz") ||
      endsWith(name, ".dcm")) {
    return FileKind::Image;
  }
  if (endsWith(name, ".tfm") || endsWith(name, ".h5") || endsWith(name, ".hdf5") || endsWith(name, ".mat") ||
      endsWith(name, ".txt")) {
    return FileKind::Transform;
  }
  if (std::filesystem::is_regular_file(path, ec) && io::hasDicomPreamble(path)) return FileKind::Image;
  return FileKind::Unknown;
}

}  // namespace mrsns::cli
