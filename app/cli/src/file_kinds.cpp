#include "file_kinds.h"

#include <algorithm>
#include <cctype>
#include <fstream>

#include "mrsns/io/sequence_file.h"

namespace mrsns::cli {
namespace {

std::string lowerName(const std::filesystem::path& path) {
  std::string name = path.filename().string();
  std::transform(name.begin(), name.end(), name.begin(), [](unsigned char c) { return std::tolower(c); });
  return name;
}

bool endsWith(const std::string& s, const std::string& suffix) {
  return s.size() >= suffix.size() && s.compare(s.size() - suffix.size(), suffix.size(), suffix) == 0;
}

bool startsWithDicomPreamble(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  char buffer[132] = {};
  if (!in.read(buffer, sizeof buffer)) return false;
  return std::string(buffer + 128, 4) == "DICM";
}

}  // namespace

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
  const std::string name = lowerName(path);
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
  if (std::filesystem::is_regular_file(path, ec) && startsWithDicomPreamble(path)) return FileKind::Image;
  return FileKind::Unknown;
}

}  // namespace mrsns::cli
