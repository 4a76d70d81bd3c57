// `info` and `convert` for volumes (NRRD, NIfTI, MetaImage, DICOM).
#include <algorithm>
#include <limits>
#include <sstream>

#include "file_kinds.h"
#include "mrsns/io/image_io.h"

namespace mrsns::cli {
namespace {

/// Adding +0.0 turns -0.0 (from RAS->LPS flips of zero entries) into 0.0 for display.
double clean(double v) {
  return v + 0.0;
}

Json vec(const Eigen::Vector3d& v) {
  return Json::array({clean(v.x()), clean(v.y()), clean(v.z())});
}

}  // namespace

Report summarizeImage(const std::filesystem::path& path) {
  const io::ImageReadResult read = io::readImageFile(path);
  const ImageVolume& image = read.image;
  Report report;
  auto& j = report.json;
  j["file"] = path.string();
  j["kind"] = "image";
  j["format"] = io::imageFormatName(read.format);
  j["size"] = {image.size[0], image.size[1], image.size[2]};
  j["spacing"] = vec(image.spacing);
  j["origin"] = vec(image.origin);
  j["coordinate_system"] = "LPS";
  // Rows of the direction matrix; its columns are the i, j, k axes in LPS.
  j["direction"] = Json::array();
  for (int r = 0; r < 3; ++r) {
    j["direction"].push_back(
        Json::array({clean(image.direction(r, 0)), clean(image.direction(r, 1)), clean(image.direction(r, 2))}));
  }
  j["pixel_type"] = pixelTypeName(image.pixel_type);
  j["physical_extent_mm"] = vec(image.physicalExtent());
  double lo = std::numeric_limits<double>::infinity(), hi = -lo;
  for (std::size_t i = 0; i < image.voxelCount(); ++i) {
    const double v = image.valueAtIndex(i);
    lo = std::min(lo, v);
    hi = std::max(hi, v);
  }
  j["value_range"] = {lo, hi};
  std::vector<io::DicomSeriesInfo> series;
  if (read.format == io::ImageFormat::Dicom) {
    j["dicom_files"] = read.file_count;
    j["series_id"] = read.series_uid;
    if (read.series_in_folder > 0) j["series_in_folder"] = read.series_in_folder;
    j["slice_gap_deviation_mm"] = read.slice_gap_deviation_mm;
    // What was read (never the patient's name).
    j["modality"] = read.modality;
    j["series_description"] = read.series_description;
    j["series_instance_uid"] = read.series_instance_uid;
    j["patient_id"] = read.patient_id;
    j["study_date"] = read.study_date;
    std::error_code ec;
    if (std::filesystem::is_directory(path, ec)) {
      // Every series of the folder, in the order whose 1-based index chooses one (the first, the largest, is
      // the one read above); io::ImageReadOptions::dicom_series takes the index, uid or series_instance_uid.
      series = io::listDicomSeries(path);
      j["series"] = Json::array();
      for (std::size_t i = 0; i < series.size(); ++i) {
        const auto& s = series[i];
        j["series"].push_back({{"index", i + 1},
                               {"uid", s.uid},
                               {"series_instance_uid", s.series_instance_uid},
                               {"series_number", s.series_number},
                               {"modality", s.modality},
                               {"description", s.description},
                               {"files", s.files},
                               {"rows", s.rows},
                               {"columns", s.columns},
                               {"patient_id", s.patient_id},
                               {"study_date", s.study_date},
                               {"body_part", s.body_part},
                               {"read", s.uid == read.series_uid}});
      }
    }
  }
  std::optional<std::vector<io::LabelCount>> labels;
  if (isIntegerPixelType(image.pixel_type) || image.pixel_type == PixelType::Float64 ||
      image.pixel_type == PixelType::Float32) {
    labels = io::labelStatistics(image, 256);
  }
  if (labels) {
    j["labels"] = Json::array();
    for (const auto& l : *labels) {
      j["labels"].push_back({{"value", l.value},
                             {"voxels", l.voxels},
                             {"volume_ml", static_cast<double>(l.voxels) * image.voxelVolume() / 1000.0}});
    }
  }

  std::ostringstream t;
  t << path.string() << ": image (" << j["format"].get<std::string>() << ", " << pixelTypeName(image.pixel_type)
    << ")\n"
    << "  size: " << image.size[0] << " x " << image.size[1] << " x " << image.size[2] << "\n"
    << "  spacing (mm): " << image.spacing.x() << ", " << image.spacing.y() << ", " << image.spacing.z() << "\n"
    << "  origin (LPS mm): " << image.origin.x() << ", " << image.origin.y() << ", " << image.origin.z() << "\n"
    << "  direction (columns = i, j, k in LPS):\n";
  for (int r = 0; r < 3; ++r) {
    t << "    " << clean(image.direction(r, 0)) << " " << clean(image.direction(r, 1)) << " "
      << clean(image.direction(r, 2)) << "\n";
  }
  t << "  values: " << lo << " .. " << hi << "\n";
  if (read.format == io::ImageFormat::Dicom) {
    t << "  DICOM files: " << read.file_count << ", modality " << (read.modality.empty() ? "(none)" : read.modality);
    if (!read.series_description.empty()) t << ", \"" << read.series_description << "\"";
    t << "\n";
  }
  if (series.size() > 1) {
    t << "  series in the folder (the first is read; choose another by its index, uid or SeriesInstanceUID):\n";
    for (std::size_t i = 0; i < series.size(); ++i) {
      const auto& s = series[i];
      t << "    " << i + 1 << ": series " << (s.series_number.empty() ? "-" : s.series_number) << ", "
        << (s.modality.empty() ? "-" : s.modality) << (s.description.empty() ? "" : " \"" + s.description + "\"")
        << ", " << s.files << (s.files == 1 ? " file, " : " files, ") << s.columns << " x " << s.rows << "\n";
    }
  }
  if (labels) {
    t << "  labels (" << labels->size() << "):";
    for (const auto& l : *labels) {
      t << " " << l.value << " (" << static_cast<double>(l.voxels) * image.voxelVolume() / 1000.0 << " ml)";
    }
    t << "\n";
  }
  report.text = t.str();
  return report;
}

Report convertImage(const std::filesystem::path& in, const std::filesystem::path& out, const ConvertOptions& options) {
  const ImageVolume image = io::readImage(in);
  io::ImageWriteOptions write;
  write.compress = options.compress;
  io::writeImage(image, out, write);
  Report report;
  report.json["file"] = in.string();
  report.json["kind"] = "image";
  report.json["written"] = out.string();
  report.json["size"] = {image.size[0], image.size[1], image.size[2]};
  report.json["pixel_type"] = pixelTypeName(image.pixel_type);
  report.text = "wrote " + out.string() + " (" + std::to_string(image.size[0]) + " x " + std::to_string(image.size[1]) +
                " x " + std::to_string(image.size[2]) + ", " + pixelTypeName(image.pixel_type) + ")\n";
  return report;
}

}  // namespace mrsns::cli
