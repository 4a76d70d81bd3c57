#pragma once
// The one place ITK is called from (itk_bridge.cpp). ITK 5.2 bundles its own
// Eigen 3.3 under the same include guards and namespace as the system Eigen
// 3.4 the rest of MR-SNS uses, so no translation unit may include both: this
// interface uses only the standard library, and image_io.cpp /
// transform_io.cpp turn it into Eigen/core types.
#include <array>
#include <cstddef>
#include <filesystem>
#include <string>
#include <vector>

namespace mrsns::io::detail {

/// Component types as in mrsns::PixelType, plus 64-bit integers the caller narrows.
enum class RawComponent { UInt8, Int8, UInt16, Int16, UInt32, Int32, Float32, Float64, Int64, UInt64 };

enum class RawImageFormat { Nrrd, Nifti, MetaImage, Dicom };

/// A scalar image as ITK's ImageIO reports it (LPS geometry).
struct RawImage {
  unsigned dimensions = 3;
  std::array<std::size_t, 3> size{1, 1, 1};
  std::array<double, 3> spacing{1, 1, 1};
  std::array<double, 3> origin{0, 0, 0};
  std::array<double, 9> direction{1, 0, 0, 0, 1, 0, 0, 0, 1};  ///< row-major; column j is axis j
  RawComponent component = RawComponent::UInt8;
  std::vector<std::byte> data;
};

/// Reads one file with the ImageIO of `format`. Throws FormatError /
/// UnsupportedError naming the file (ITK exceptions are translated).
RawImage readRawImage(RawImageFormat format, const std::filesystem::path& path);

/// Writes `data` with the geometry and type of `header` (whose own data is
/// ignored) using the ImageIO of `format`; throws FileError naming the file.
void writeRawImage(const RawImage& header, const std::vector<std::byte>& data, RawImageFormat format,
                   const std::filesystem::path& path, bool compress);

/// Tags of one DICOM file as text, DICOM padding trimmed; empty (0) when absent.
struct DicomTags {
  std::string series_instance_uid;  ///< 0020|000e
  std::string series_description;   ///< 0008|103e
  std::string modality;             ///< 0008|0060
  std::string series_number;        ///< 0020|0011
  int rows = 0;                     ///< 0028|0010
  int columns = 0;                  ///< 0028|0011
  std::string patient_id;           ///< 0010|0020
  std::string patient_name;         ///< 0010|0010
  std::string study_date;           ///< 0008|0020
  std::string body_part;            ///< 0018|0015
};

/// One series of a folder as GDCM groups it.
struct DicomSeriesFiles {
  std::string uid;                 ///< ITK's series id (SeriesInstanceUID + series details)
  std::vector<std::string> files;  ///< in GDCM's order (by image position)
  DicomTags tags;                  ///< of its first file
};

/// Every DICOM series in a folder (not its subfolders), in GDCM's order;
/// empty when there is none. Throws FormatError when the scan fails.
std::vector<DicomSeriesFiles> findDicomSeries(const std::filesystem::path& folder);

/// The tags of one DICOM file (its header only, any SOP class: images, SR
/// reports). Throws FormatError naming the file when it is not DICOM.
DicomTags readDicomTags(const std::filesystem::path& file);

/// One ITK transform as stored in a file.
struct RawTransform {
  std::string class_name;  ///< e.g. "AffineTransform_double_3_3"
  std::vector<double> parameters;
  std::vector<double> fixed_parameters;
  bool linear = false;             ///< a MatrixOffsetTransformBase (matrix + offset exactly describe it)
  std::array<double, 9> matrix{};  ///< row-major, when linear
  std::array<double, 3> offset{};  ///< when linear: T(x) = matrix x + offset
};

/// The transforms of an ITK transform file (.tfm/.txt, .h5/.hdf5, .mat) in
/// file order; a composite transform is flattened into its components in
/// the order they are applied (first applied first).
std::vector<RawTransform> readRawTransforms(const std::filesystem::path& path);

/// Writes one affine transform (matrix, offset) as "AffineTransform_double_3_3".
void writeRawAffine(const std::array<double, 9>& matrix, const std::array<double, 3>& offset,
                    const std::filesystem::path& path);

}  // namespace mrsns::io::detail
