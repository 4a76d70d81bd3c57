#pragma once
// Landmark files: 3D Slicer markups (.mrk.json, schema markups-schema-v1.0.x),
// legacy Slicer .fcsv, and plain CSV/whitespace point lists
// ("label,x,y,z" or "x y z" per line). Positions are converted to LPS on
// reading (Slicer may store RAS) and written in LPS.
#include <filesystem>
#include <string>

#include "mrsns/core/landmarks.h"

namespace mrsns::io {

/// What a landmark file held besides its points.
struct LandmarksFileInfo {
  std::string format;             ///< "mrk.json", "fcsv", "csv"
  std::string coordinate_system;  ///< as declared by the file: "LPS", "RAS", or "unspecified" (taken as LPS)
  std::string markup_type;        ///< Slicer markup type ("Fiducial", "Line", ...); empty for fcsv/csv
  int markups_in_file = 1;        ///< a .mrk.json may hold several markups; only the first is read
};

struct LandmarksReadResult {
  LandmarkSet landmarks;  ///< positions in LPS mm
  LandmarksFileInfo info;
};

/// Reads any supported landmark file, chosen by extension (.mrk.json, .json,
/// .fcsv, .csv, .txt). Throws FileError when the file cannot be opened,
/// FormatError (naming the file) when it is malformed or holds no points,
/// UnsupportedError for an unknown coordinate system.
LandmarksReadResult readLandmarksFile(const std::filesystem::path& path);

/// readLandmarksFile(path).landmarks.
LandmarkSet readLandmarks(const std::filesystem::path& path);

/// Writes by extension: .mrk.json (Slicer markups, Fiducial, LPS), .fcsv
/// (version 4.11, LPS) or .csv (label,x,y,z in LPS). Throws UnsupportedError
/// for other extensions, FileError when the file cannot be written.
void writeLandmarks(const LandmarkSet& landmarks, const std::filesystem::path& path);

void writeMarkupsJson(const LandmarkSet& landmarks, const std::filesystem::path& path);
void writeFcsv(const LandmarkSet& landmarks, const std::filesystem::path& path);
void writeLandmarksCsv(const LandmarkSet& landmarks, const std::filesystem::path& path);

}  // namespace mrsns::io
