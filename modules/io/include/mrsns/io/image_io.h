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

struct ImageReadResult {
  ImageVolume image;
  ImageFormat format = ImageFormat::Nrrd;
  std::size_t file_count = 1;        ///< DICOM series: slices read
  std::string series_uid;            ///< DICOM: ITK's series id (SeriesInstanceUID + series details)
  std::size_t series_in_folder = 0;  ///< DICOM folder: how many series it holds (the largest is read)
  /// DICOM series: largest deviation of a slice gap from the mean gap (mm);
  /// a few percent of the spacing means missing or irregular slices.
  double slice_gap_deviation_mm = 0.0;
};

/// Reads a volume file or DICOM series folder. Scalar images of 2 or 3
/// dimensions (a 2D image gets size[2] = 1); 64-bit integer voxels are
/// narrowed to int32 when every value fits, else stored as float64.
/// Throws FileError (missing/unreadable), UnsupportedError (unknown format,
/// multi-component or 4D data), FormatError naming the file for malformed or
/// truncated content.
ImageReadResult readImageFile(const std::filesystem::path& path);

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
