#pragma once
// How the readers recognise files: lower-cased names and extensions, suffix
// tests (".nii.gz", ".seq.nrrd"), and the DICOM preamble. One copy for io
// and the CLI.
#include <algorithm>
#include <cctype>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <string>
#include <string_view>

namespace mrsns::io {

inline std::string toLower(std::string s) {
  std::transform(s.begin(), s.end(), s.begin(), [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return s;
}

/// The file name (no folder), lower case: "CT.Nii.GZ" -> "ct.nii.gz".
inline std::string lowerFileName(const std::filesystem::path& path) {
  return toLower(path.filename().string());
}

/// The last extension, lower case, with its dot: ".stl".
inline std::string lowerExtension(const std::filesystem::path& path) {
  return toLower(path.extension().string());
}

inline bool endsWith(std::string_view s, std::string_view suffix) {
  return s.size() >= suffix.size() && s.compare(s.size() - suffix.size(), suffix.size(), suffix) == 0;
}

/// True for a DICOM Part 10 file ("DICM" after the 128-byte preamble).
inline bool hasDicomPreamble(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  char buffer[132] = {};
  if (!in.read(buffer, sizeof buffer)) return false;
  return std::memcmp(buffer + 128, "DICM", 4) == 0;
}

}  // namespace mrsns::io
