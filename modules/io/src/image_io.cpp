// Image files in and out of ImageVolume: formats, geometry checks, DICOM
// series stacking and label statistics. ITK is reached only through
// itk_bridge.h (see there why).
#include "mrsns/io/image_io.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstring>
#include <fstream>
#include <limits>
#include <map>

#include "header_checks.h"
#include "itk_bridge.h"
#include "io_text.h"
#include "mrsns/core/error.h"
#include "mrsns/core/log.h"
#include "mrsns/io/file_names.h"

namespace mrsns::io {
namespace {

using detail::quoted;


detail::RawImageFormat rawFormat(ImageFormat format) {
  switch (format) {
    case ImageFormat::Nrrd: return detail::RawImageFormat::Nrrd;
    case ImageFormat::Nifti: return detail::RawImageFormat::Nifti;
    case ImageFormat::MetaImage: return detail::RawImageFormat::MetaImage;
    case ImageFormat::Dicom: return detail::RawImageFormat::Dicom;
  }
  return detail::RawImageFormat::Nrrd;
}

/// 64-bit integer voxels: int32 when every value fits, else float64.
template <typename Int64>
std::vector<std::byte> narrowWideIntegers(const std::vector<std::byte>& raw, PixelType& type) {
  const std::size_t n = raw.size() / 8;
  std::vector<Int64> values(n);
  std::memcpy(values.data(), raw.data(), n * 8);
  const bool fits = std::all_of(values.begin(), values.end(), [](Int64 v) {
    return static_cast<long double>(v) >= std::numeric_limits<std::int32_t>::min() &&
           static_cast<long double>(v) <= std::numeric_limits<std::int32_t>::max();
  });
  std::vector<std::byte> out;
  if (fits) {
    type = PixelType::Int32;
    out.resize(n * 4);
    for (std::size_t i = 0; i < n; ++i) {
      const auto v = static_cast<std::int32_t>(values[i]);
      std::memcpy(out.data() + i * 4, &v, 4);
    }
  } else {
    type = PixelType::Float64;
    out.resize(n * 8);
    for (std::size_t i = 0; i < n; ++i) {
      const auto v = static_cast<double>(values[i]);
      std::memcpy(out.data() + i * 8, &v, 8);
    }
  }
  return out;
}

void checkGeometry(const ImageVolume& image, const std::filesystem::path& path) {
  if (!image.spacing.allFinite() || (image.spacing.array() <= 0.0).any()) {
    throw FormatError("image " + quoted(path) + " has an invalid spacing (" + std::to_string(image.spacing.x()) + ", " +
                      std::to_string(image.spacing.y()) + ", " + std::to_string(image.spacing.z()) + ")");
  }
  if (!image.origin.allFinite() || !image.direction.allFinite() || std::abs(image.direction.determinant()) < 1e-6) {
    throw FormatError("image " + quoted(path) + " has an invalid origin or a singular direction matrix");
  }
}

ImageVolume fromRaw(detail::RawImage raw, const std::filesystem::path& path) {
  ImageVolume image;
  image.name = path.filename().string();
  for (int axis = 0; axis < 3; ++axis) {
    image.size[static_cast<std::size_t>(axis)] = static_cast<int>(raw.size[static_cast<std::size_t>(axis)]);
    image.spacing[axis] = raw.spacing[static_cast<std::size_t>(axis)];
    image.origin[axis] = raw.origin[static_cast<std::size_t>(axis)];
    for (int row = 0; row < 3; ++row)
      image.direction(row, axis) = raw.direction[static_cast<std::size_t>(row * 3 + axis)];
  }
  checkGeometry(image, path);
  using C = detail::RawComponent;
  switch (raw.component) {
    case C::UInt8: image.pixel_type = PixelType::UInt8; break;
    case C::Int8: image.pixel_type = PixelType::Int8; break;
    case C::UInt16: image.pixel_type = PixelType::UInt16; break;
    case C::Int16: image.pixel_type = PixelType::Int16; break;
    case C::UInt32: image.pixel_type = PixelType::UInt32; break;
    case C::Int32: image.pixel_type = PixelType::Int32; break;
    case C::Float32: image.pixel_type = PixelType::Float32; break;
    case C::Float64: image.pixel_type = PixelType::Float64; break;
    case C::Int64: raw.data = narrowWideIntegers<std::int64_t>(raw.data, image.pixel_type); break;
    case C::UInt64: raw.data = narrowWideIntegers<std::uint64_t>(raw.data, image.pixel_type); break;
  }
  image.data = std::move(raw.data);
  if (image.data.size() != image.byteCount()) {
    throw FormatError("image " + quoted(path) + ": read " + std::to_string(image.data.size()) + " bytes of voxels, " +
                      std::to_string(image.byteCount()) + " expected from its header");
  }
  return image;
}

/// Re-stores a volume's voxels as float64 (slices of a series whose rescale
/// gave them different types).
void toFloat64(ImageVolume& image) {
  if (image.pixel_type == PixelType::Float64) return;
  std::vector<std::byte> out(image.voxelCount() * 8);
  for (std::size_t i = 0; i < image.voxelCount(); ++i) {
    const double v = image.valueAtIndex(i);
    std::memcpy(out.data() + i * 8, &v, 8);
  }
  image.data = std::move(out);
  image.pixel_type = PixelType::Float64;
}

DicomSeriesInfo seriesInfo(const detail::DicomSeriesFiles& s) {
  DicomSeriesInfo info;
  info.uid = s.uid;
  info.series_instance_uid = s.tags.series_instance_uid;
  info.description = s.tags.series_description;
  info.modality = s.tags.modality;
  info.series_number = s.tags.series_number;
  info.files = s.files.size();
  info.rows = s.tags.rows;
  info.columns = s.tags.columns;
  info.patient_id = s.tags.patient_id;
  info.patient_name = s.tags.patient_name;
  info.study_date = s.tags.study_date;
  info.body_part = s.tags.body_part;
  return info;
}

/// A series number as a number for sorting; none or not a number sorts last.
long long seriesNumberKey(const std::string& number) {
  if (number.empty() || !std::all_of(number.begin(), number.end(), [](unsigned char c) { return std::isdigit(c); }) ||
      number.size() > 15) {
    return std::numeric_limits<long long>::max();
  }
  return std::stoll(number);
}

/// The folder's series in listDicomSeries' order (largest first, then series number, then uid).
std::vector<detail::DicomSeriesFiles> sortedDicomSeries(const std::filesystem::path& folder) {
  std::vector<detail::DicomSeriesFiles> series = detail::findDicomSeries(folder);
  std::sort(series.begin(), series.end(), [](const detail::DicomSeriesFiles& a, const detail::DicomSeriesFiles& b) {
    if (a.files.size() != b.files.size()) return a.files.size() > b.files.size();
    const long long na = seriesNumberKey(a.tags.series_number), nb = seriesNumberKey(b.tags.series_number);
    if (na != nb) return na < nb;
    return a.uid < b.uid;
  });
  return series;
}

/// "1: series 2, CT "CT Body 3.0", 20 files; 2: ..." for messages (no patient data).
std::string seriesListing(const std::vector<detail::DicomSeriesFiles>& series) {
  std::string text;
  for (std::size_t i = 0; i < series.size(); ++i) {
    const auto& t = series[i].tags;
    if (!text.empty()) text += "; ";
    text += std::to_string(i + 1) + ": series " + (t.series_number.empty() ? "(no number)" : t.series_number) + ", " +
            (t.modality.empty() ? "no modality" : t.modality) +
            (t.series_description.empty() ? "" : " \"" + t.series_description + "\"") + ", " +
            std::to_string(series[i].files.size()) + (series[i].files.size() == 1 ? " file" : " files");
  }
  return text;
}

/// The index in `series` that `choice` names (see ImageReadOptions::dicom_series).
std::size_t chooseDicomSeries(const std::vector<detail::DicomSeriesFiles>& series, std::string choice,
                              const std::filesystem::path& folder) {
  // A value pasted from a listing may carry spaces (or DICOM's padding).
  const auto keep = [](unsigned char c) { return c != '\0' && !std::isspace(c); };
  choice.erase(std::find_if(choice.rbegin(), choice.rend(), keep).base(), choice.end());
  choice.erase(choice.begin(), std::find_if(choice.begin(), choice.end(), keep));
  if (choice.empty()) return 0;
  for (std::size_t i = 0; i < series.size(); ++i) {
    if (series[i].uid == choice) return i;
  }
  std::vector<std::size_t> by_instance_uid;
  for (std::size_t i = 0; i < series.size(); ++i) {
    if (series[i].tags.series_instance_uid == choice) by_instance_uid.push_back(i);
  }
  const std::string how = "; choose one by its index (1 to " + std::to_string(series.size()) +
                          "), uid or SeriesInstanceUID, as `mrsns-cli info FOLDER --json` lists them";
  if (by_instance_uid.size() == 1) return by_instance_uid.front();
  if (by_instance_uid.size() > 1) {
    throw InvalidArgumentError("DICOM folder " + quoted(folder) + ": SeriesInstanceUID '" + choice + "' holds " +
                               std::to_string(by_instance_uid.size()) +
                               " series of different image sizes or numbers (" + seriesListing(series) + ")" + how);
  }
  const bool digits =
      choice.size() <= 9 && std::all_of(choice.begin(), choice.end(), [](unsigned char c) { return std::isdigit(c); });
  if (digits) {
    const auto index = static_cast<std::size_t>(std::stoul(choice));
    if (index >= 1 && index <= series.size()) return index - 1;
  }
  throw InvalidArgumentError("DICOM folder " + quoted(folder) + " has no series '" + choice + "'; it holds " +
                             std::to_string(series.size()) + ": " + seriesListing(series) + how);
}

ImageReadResult readDicomSeries(const std::filesystem::path& folder, const std::string& choice) {
  const std::vector<detail::DicomSeriesFiles> all = sortedDicomSeries(folder);
  if (all.empty()) {
    throw FormatError("folder " + quoted(folder) +
                      " holds no DICOM image series: choose the folder that holds the series' files");
  }
  const detail::DicomSeriesFiles& series = all[chooseDicomSeries(all, choice, folder)];
  ImageReadResult result;
  result.format = ImageFormat::Dicom;
  result.series_in_folder = all.size();
  result.series_uid = series.uid;
  result.modality = series.tags.modality;
  result.series_description = series.tags.series_description;
  result.series_instance_uid = series.tags.series_instance_uid;
  result.patient_id = series.tags.patient_id;
  result.study_date = series.tags.study_date;
  if (all.size() > 1 && choice.empty()) {
    logger()->warn(
        "folder '{}' holds {} DICOM series ({}); reading 1, the largest; choose another by its index, uid "
        "or SeriesInstanceUID",
        folder.string(), all.size(), seriesListing(all));
  }
  std::vector<ImageVolume> slices;
  slices.reserve(series.files.size());
  for (const auto& f : series.files)
    slices.push_back(fromRaw(detail::readRawImage(detail::RawImageFormat::Dicom, f), f));
  const ImageVolume first = slices.front();
  const Eigen::Vector3d normal = first.direction.col(2).normalized();
  for (const auto& s : slices) {
    if (s.size[0] != first.size[0] || s.size[1] != first.size[1] || s.size[2] != 1) {
      throw FormatError("DICOM series in " + quoted(folder) + " mixes slice sizes (" + s.name + " is " +
                        std::to_string(s.size[0]) + "x" + std::to_string(s.size[1]) + "x" + std::to_string(s.size[2]) +
                        ")");
    }
  }
  // Order along the slice normal ourselves rather than trusting file order.
  std::stable_sort(slices.begin(), slices.end(), [&](const ImageVolume& a, const ImageVolume& b) {
    return normal.dot(a.origin) < normal.dot(b.origin);
  });
  const bool mixed_types = std::any_of(slices.begin(), slices.end(),
                                       [&](const ImageVolume& s) { return s.pixel_type != slices.front().pixel_type; });
  if (mixed_types) {
    for (auto& s : slices) toFloat64(s);
  }
  ImageVolume image;
  image.name = folder.filename().string();
  image.size = {first.size[0], first.size[1], static_cast<int>(slices.size())};
  image.origin = slices.front().origin;
  image.direction = slices.front().direction;
  image.spacing = slices.front().spacing;
  image.pixel_type = slices.front().pixel_type;
  if (slices.size() > 1) {
    const Eigen::Vector3d step = slices.back().origin - slices.front().origin;
    const double span = normal.dot(step);
    if (span <= 0.0) {
      throw FormatError("DICOM series in " + quoted(folder) +
                        " has its slices at one position (several frames or echoes per location?): cannot stack them");
    }
    image.spacing.z() = span / static_cast<double>(slices.size() - 1);
    if ((step.normalized() - normal).norm() > 1e-3) {
      logger()->warn("DICOM series in '{}': slices step off the slice normal (gantry tilt?); geometry uses the normal",
                     folder.string());
    }
    for (std::size_t i = 1; i < slices.size(); ++i) {
      const double gap = normal.dot(slices[i].origin - slices[i - 1].origin);
      result.slice_gap_deviation_mm = std::max(result.slice_gap_deviation_mm, std::abs(gap - image.spacing.z()));
    }
    if (result.slice_gap_deviation_mm > 0.01 * image.spacing.z()) {
      logger()->warn("DICOM series in '{}': slice gaps deviate up to {:.3f} mm from {:.3f} mm (missing slices?)",
                     folder.string(), result.slice_gap_deviation_mm, image.spacing.z());
    }
  }
  const std::size_t slice_bytes = first.voxelCount() * pixelTypeSize(image.pixel_type);
  image.data.resize(slice_bytes * slices.size());
  for (std::size_t k = 0; k < slices.size(); ++k) {
    std::memcpy(image.data.data() + k * slice_bytes, slices[k].data.data(), slice_bytes);
  }
  checkGeometry(image, folder);
  result.file_count = slices.size();
  result.image = std::move(image);
  return result;
}

}  // namespace

std::string imageFormatName(ImageFormat format) {
  switch (format) {
    case ImageFormat::Nrrd: return "nrrd";
    case ImageFormat::Nifti: return "nifti";
    case ImageFormat::MetaImage: return "metaimage";
    case ImageFormat::Dicom: return "dicom";
  }
  return "unknown";
}

ImageFormat imageFormatFromPath(const std::filesystem::path& path) {
  std::error_code ec;
  if (std::filesystem::is_directory(path, ec)) return ImageFormat::Dicom;
  const std::string name = lowerFileName(path);
  if (endsWith(name, ".nrrd") || endsWith(name, ".nhdr")) return ImageFormat::Nrrd;
  if (endsWith(name, ".nii") || endsWith(name, ".nii.gz")) return ImageFormat::Nifti;
  if (endsWith(name, ".mha") || endsWith(name, ".mhd")) return ImageFormat::MetaImage;
  if (endsWith(name, ".dcm") || endsWith(name, ".dicom")) return ImageFormat::Dicom;
  if (std::filesystem::is_regular_file(path, ec) && hasDicomPreamble(path)) return ImageFormat::Dicom;
  throw UnsupportedError("image " + quoted(path) +
                         " is not a known image format: use .nrrd/.nhdr, .nii/.nii.gz, .mha/.mhd, DICOM files or a "
                         "DICOM series folder");
}

std::vector<DicomSeriesInfo> listDicomSeries(const std::filesystem::path& folder) {
  std::error_code ec;
  if (!std::filesystem::is_directory(folder, ec)) {
    throw FileError("DICOM folder " + quoted(folder) +
                    (std::filesystem::exists(folder, ec) ? " is a file, not a folder: give the folder that holds it"
                                                         : " does not exist: check the path"));
  }
  std::vector<DicomSeriesInfo> out;
  for (const auto& s : sortedDicomSeries(folder)) out.push_back(seriesInfo(s));
  return out;
}

ImageReadResult readImageFile(const std::filesystem::path& path) {
  return readImageFile(path, ImageReadOptions{});
}

ImageReadResult readImageFile(const std::filesystem::path& path, const ImageReadOptions& options) {
  std::error_code ec;
  if (!std::filesystem::exists(path, ec)) {
    throw FileError("image " + quoted(path) + " does not exist: check the path");
  }
  const ImageFormat format = imageFormatFromPath(path);
  if (std::filesystem::is_directory(path, ec)) return readDicomSeries(path, options.dicom_series);
  if (!options.dicom_series.empty()) {
    throw InvalidArgumentError("image " + quoted(path) + " is a single " + imageFormatName(format) +
                               " file, not a DICOM folder: a series ('" + options.dicom_series +
                               "') can only be chosen in a folder; give the folder, or no series");
  }
  {
    std::ifstream probe(path, std::ios::binary);
    if (!probe) throw FileError("cannot open image " + quoted(path) + ": check its permissions");
  }
  ImageReadResult result;
  result.format = format;
  if (format == ImageFormat::Nifti) detail::checkNiftiLength(path);
  if (format == ImageFormat::MetaImage) detail::checkMetaImageLength(path);
  try {
    result.image = fromRaw(detail::readRawImage(rawFormat(format), path), path);
  } catch (const FormatError& e) {
    if (format != ImageFormat::Nifti || std::string(e.what()).find("orthonormal") == std::string::npos) throw;
    const auto repaired = detail::niftiWithQformFromSform(path);
    if (!repaired) throw;
    // Float rounding of a rotation is routine; a visible shear is worth a warning.
    logger()->log(repaired->deviation > 1e-4 ? spdlog::level::warn : spdlog::level::debug,
                  "NIfTI '{}': sform direction is orthonormal only within {:.2g}; reading its nearest rotation",
                  path.string(), repaired->deviation);
    struct Remove {
      std::filesystem::path p;
      ~Remove() {
        std::error_code ignored;
        std::filesystem::remove(p, ignored);
      }
    } cleanup{repaired->path};
    result.image = fromRaw(detail::readRawImage(rawFormat(format), repaired->path), path);
  }
  if (format == ImageFormat::Dicom) {
    const detail::DicomTags tags = detail::readDicomTags(path);
    result.modality = tags.modality;
    result.series_description = tags.series_description;
    result.series_instance_uid = tags.series_instance_uid;
    result.patient_id = tags.patient_id;
    result.study_date = tags.study_date;
  }
  return result;
}

ImageVolume readImage(const std::filesystem::path& path) {
  return readImageFile(path).image;
}

void writeImage(const ImageVolume& image, const std::filesystem::path& path, const ImageWriteOptions& options) {
  const std::string name = lowerFileName(path);
  ImageFormat format = ImageFormat::Nrrd;
  if (endsWith(name, ".nrrd") || endsWith(name, ".nhdr")) {
    format = ImageFormat::Nrrd;
  } else if (endsWith(name, ".nii") || endsWith(name, ".nii.gz")) {
    format = ImageFormat::Nifti;
  } else if (endsWith(name, ".mha") || endsWith(name, ".mhd")) {
    format = ImageFormat::MetaImage;
  } else {
    throw UnsupportedError("cannot write image " + quoted(path) + ": use .nrrd, .nhdr, .nii, .nii.gz, .mha or .mhd");
  }
  if (image.empty() || std::any_of(image.size.begin(), image.size.end(), [](int s) { return s <= 0; })) {
    throw InvalidArgumentError("cannot write image " + quoted(path) + ": the volume is empty");
  }
  if (image.data.size() != image.byteCount()) {
    throw InvalidArgumentError("cannot write image " + quoted(path) + ": buffer holds " +
                               std::to_string(image.data.size()) + " bytes but size and pixel type need " +
                               std::to_string(image.byteCount()));
  }
  if (!image.spacing.allFinite() || (image.spacing.array() <= 0.0).any() || !image.origin.allFinite() ||
      !image.direction.allFinite() || std::abs(image.direction.determinant()) < 1e-6) {
    throw InvalidArgumentError("cannot write image " + quoted(path) +
                               ": spacing must be positive and the direction matrix invertible");
  }
  detail::RawImage raw;
  for (int axis = 0; axis < 3; ++axis) {
    const auto a = static_cast<std::size_t>(axis);
    raw.size[a] = static_cast<std::size_t>(image.size[a]);
    raw.spacing[a] = image.spacing[axis];
    raw.origin[a] = image.origin[axis];
    for (int row = 0; row < 3; ++row)
      raw.direction[static_cast<std::size_t>(row * 3 + axis)] = image.direction(row, axis);
  }
  using C = detail::RawComponent;
  switch (image.pixel_type) {
    case PixelType::UInt8: raw.component = C::UInt8; break;
    case PixelType::Int8: raw.component = C::Int8; break;
    case PixelType::UInt16: raw.component = C::UInt16; break;
    case PixelType::Int16: raw.component = C::Int16; break;
    case PixelType::UInt32: raw.component = C::UInt32; break;
    case PixelType::Int32: raw.component = C::Int32; break;
    case PixelType::Float32: raw.component = C::Float32; break;
    case PixelType::Float64: raw.component = C::Float64; break;
  }
  // The bridge only reads the buffer; avoid copying a large volume.
  raw.data.clear();
  detail::writeRawImage(raw, image.data, rawFormat(format), path, options.compress);
  std::error_code ec;
  if (!std::filesystem::exists(path, ec)) {
    throw FileError("writing image " + quoted(path) + " failed: no file was created");
  }
}

std::optional<std::vector<LabelCount>> labelStatistics(const ImageVolume& image, std::size_t max_labels) {
  const std::size_t n = image.voxelCount();
  if (image.data.size() < image.byteCount()) return std::nullopt;
  // Small integer types: a dense histogram is faster than a map.
  if (image.pixel_type == PixelType::UInt8 || image.pixel_type == PixelType::Int8 ||
      image.pixel_type == PixelType::UInt16 || image.pixel_type == PixelType::Int16) {
    const bool wide = pixelTypeSize(image.pixel_type) == 2;
    const std::int64_t offset = (image.pixel_type == PixelType::Int8)    ? 128
                                : (image.pixel_type == PixelType::Int16) ? 32768
                                                                         : 0;
    std::vector<std::size_t> histogram(wide ? 65536 : 256, 0);
    for (std::size_t i = 0; i < n; ++i) {
      const auto v = static_cast<std::int64_t>(image.valueAtIndex(i));
      ++histogram[static_cast<std::size_t>(v + offset)];
    }
    std::vector<LabelCount> labels;
    for (std::size_t b = 0; b < histogram.size(); ++b) {
      if (histogram[b] == 0) continue;
      if (labels.size() == max_labels) return std::nullopt;
      labels.push_back({static_cast<std::int64_t>(b) - offset, histogram[b]});
    }
    return labels;
  }
  std::map<std::int64_t, std::size_t> counts;
  for (std::size_t i = 0; i < n; ++i) {
    const double v = image.valueAtIndex(i);
    if (!std::isfinite(v) || v != std::floor(v) || std::abs(v) > 9.0e15) return std::nullopt;
    auto [it, inserted] = counts.try_emplace(static_cast<std::int64_t>(v), 0);
    ++it->second;
    if (inserted && counts.size() > max_labels) return std::nullopt;
  }
  std::vector<LabelCount> labels;
  labels.reserve(counts.size());
  for (const auto& [value, voxels] : counts) labels.push_back({value, voxels});
  return labels;
}

}  // namespace mrsns::io
