#pragma once
// Header checks ITK 5.2 does not make (or makes too strictly), done on the
// raw NIfTI-1 and MetaImage headers. Internal to the io module.
#include <filesystem>
#include <optional>

namespace mrsns::io::detail {

/// Throws FormatError naming the file when a NIfTI-1 file (.nii or .nii.gz)
/// holds fewer voxel bytes than its header declares. ITK reads a truncated
/// uncompressed .nii without complaint. Non-NIfTI-1 files are left alone.
void checkNiftiLength(const std::filesystem::path& path);

/// Throws FormatError naming the file when a MetaImage (.mha with LOCAL
/// data, or .mhd with one data file) holds fewer bytes than its header
/// declares: ITK's MetaIO only prints a warning and returns partial data.
void checkMetaImageLength(const std::filesystem::path& path);

/// ITK 5.2 refuses a NIfTI file without a qform whose sform is a rotation
/// only up to float rounding ("No orthonormal definition found"), as written
/// by many tools (e.g. the VerSe data). When the sform's direction part is
/// orthonormal within `tolerance`, writes a temporary uncompressed copy whose
/// qform holds the nearest rotation and the sform offset, and returns its
/// path (the caller deletes it) and the deviation found; nullopt otherwise.
struct RepairedNifti {
  std::filesystem::path path;
  double deviation = 0.0;
};
std::optional<RepairedNifti> niftiWithQformFromSform(const std::filesystem::path& path, double tolerance = 1e-2);

}  // namespace mrsns::io::detail
