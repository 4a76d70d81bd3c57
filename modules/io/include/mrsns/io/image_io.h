#pragma once
// Volume files: NRRD (.nrrd/.nhdr), NIfTI (.nii, .nii.gz), MetaImage
// (.mha/.mhd), single DICOM files and DICOM series folders. Every reader
// returns the geometry in LPS (ITK's convention; NIfTI's RAS header is
// converted), so ImageVolume::ijkToLps() is right whatever the source.
#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "mrsns/core/image.h"

namespace mrsns::io {

enum class ImageFormat { Nrrd, Nifti, MetaImage, Dicom };

/// "nrrd", "nifti", "metaimage", "dicom".
std::string imageFormatName(ImageFormat format);

/// The format a path names: a folder is a DICOM series; otherwise the
/// extension, then the DICOM preamble. Throws UnsupportedError otherwise.
ImageFormat imageFormatFromPath(const std::filesystem::path& path);

/// One series of a DICOM folder, from the header of its first file (text as
/// in the file, DICOM padding trimmed; empty or 0 when the tag is absent).
struct DicomSeriesInfo {
  std::string uid;                  ///< ITK's series id: SeriesInstanceUID + series details (unique in the folder)
  std::string series_instance_uid;  ///< 0020|000e (anonymised data may leave it empty)
  std::string description;          ///< 0008|103e SeriesDescription, e.g. "CT Body 3.0"
  std::string modality;             ///< 0008|0060: CT, MR, US, SR (a dose report), OT, ...
  std::string series_number;        ///< 0020|0011
  std::size_t files = 0;            ///< files (slices) in the series
  int rows = 0;                     ///< 0028|0010
  int columns = 0;                  ///< 0028|0011
  std::string patient_id;           ///< 0010|0020
  std::string patient_name;         ///< 0010|0010 (identifying: never log it)
  std::string study_date;           ///< 0008|0020 (YYYYMMDD)
  std::string body_part;            ///< 0018|0015 BodyPartExamined
};

/// The DICOM series in a folder (not its subfolders): the largest first, then
/// by series number (numerically; none last), then by uid. Without a choice
/// readImageFile reads the first of this list. Empty when the folder holds no
/// DICOM file. Throws FileError when `folder` is not an existing folder,
/// FormatError when the scan fails.
std::vector<DicomSeriesInfo> listDicomSeries(const std::filesystem::path& folder);

struct ImageReadOptions {
  /// DICOM folder: the series to read, as listDicomSeries gives it: its `uid`,
  /// its SeriesInstanceUID, or its 1-based index in that list ("2"). Empty:
  /// the largest (with a warning when the folder holds several).
  std::string dicom_series;
};

struct ImageReadResult {
  ImageVolume image;
  ImageFormat format = ImageFormat::Nrrd;
  std::size_t file_count = 1;        ///< DICOM series: slices read
  std::string series_uid;            ///< DICOM: ITK's series id (SeriesInstanceUID + series details)
  std::size_t series_in_folder = 0;  ///< DICOM folder: how many series it holds
  /// DICOM series: largest deviation of a slice gap from the mean gap (mm);
  /// a few percent of the spacing means missing or irregular slices.
  double slice_gap_deviation_mm = 0.0;
  // DICOM (series or single file) only; empty for other formats.
  std::string modality;             ///< 0008|0060, e.g. "CT"; a CT import refuses "MR", "US", "SR", ...
  std::string series_description;   ///< 0008|103e
  std::string series_instance_uid;  ///< 0020|000e
  std::string patient_id;           ///< 0010|0020
  std::string study_date;           ///< 0008|0020 (YYYYMMDD)
};

/// Reads a volume file or DICOM series folder. Scalar images of 2 or 3
/// dimensions (a 2D image gets size[2] = 1); 64-bit integer voxels are
/// narrowed to int32 when every value fits, else stored as float64.
/// Throws FileError (missing/unreadable), UnsupportedError (unknown format,
/// multi-component or 4D data), FormatError naming the file for malformed or
/// truncated content.
ImageReadResult readImageFile(const std::filesystem::path& path);

/// readImageFile with a choice of DICOM series. Throws InvalidArgumentError
/// listing the folder's series (index, number, modality, description, files)
/// when `options.dicom_series` names none of them, or when a series is chosen
/// for a path that is not a DICOM folder.
ImageReadResult readImageFile(const std::filesystem::path& path, const ImageReadOptions& options);

/// readImageFile(path).image.
ImageVolume readImage(const std::filesystem::path& path);

struct ImageWriteOptions {
  bool compress = true;
};

/// Writes NRRD (.nrrd, .nhdr), NIfTI (.nii, .nii.gz) or MetaImage (.mha,
/// .mhd) by extension, preserving the pixel type and the LPS geometry.
/// Throws InvalidArgumentError for an inconsistent volume (buffer size,
/// spacing), UnsupportedError for another extension, FileError on failure.
void writeImage(const ImageVolume& image, const std::filesystem::path& path, const ImageWriteOptions& options = {});

struct LabelCount {
  std::int64_t value = 0;
  std::size_t voxels = 0;
};

/// The distinct values of an image with their voxel counts, ascending by
/// value, when the image is integer-valued (any pixel type) with at most
/// `max_labels` distinct values; nullopt otherwise (e.g. a CT in HU).
std::optional<std::vector<LabelCount>> labelStatistics(const ImageVolume& image, std::size_t max_labels = 256);

}  // namespace mrsns::io
