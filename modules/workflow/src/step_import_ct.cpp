// import-ct and import-label-map: the patient's CT and its label maps into the
// session, checked before anything is stored (a CT in Hounsfield units, a
// label map on the CT's grid).
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <map>
#include <optional>
#include <set>
#include <sstream>

#include "mrsns/core/error.h"
#include "mrsns/io/file_names.h"
#include "mrsns/io/image_io.h"
#include "mrsns/registration/label_names.h"
#include "patient_data.h"

namespace mrsns::workflow::detail {

namespace fs = std::filesystem;

namespace {

std::string vecText(const Eigen::Vector3d& v, int precision = 3) {
  std::ostringstream out;
  out.precision(precision);
  out << std::fixed << "(" << v.x() << ", " << v.y() << ", " << v.z() << ")";
  return out.str();
}

std::pair<double, double> valueRange(const ImageVolume& image) {
  double lo = std::numeric_limits<double>::infinity(), hi = -lo;
  const std::size_t n = image.voxelCount();
  for (std::size_t i = 0; i < n; ++i) {
    const double v = image.valueAtIndex(i);
    lo = std::min(lo, v);
    hi = std::max(hi, v);
  }
  return {lo, hi};
}

/// A copy of a whole-number image whose values fit 16 bits as int16 (a CT in HU stored as int32, as NIfTI
/// converters often write it, takes twice the memory and disk for nothing); the image itself otherwise.
ImageVolume narrowedToInt16(const ImageVolume& image, double lo, double hi) {
  const bool wide = image.pixel_type == PixelType::Int32 || image.pixel_type == PixelType::UInt32 ||
                    image.pixel_type == PixelType::UInt16;
  if (!wide || lo < -32768.0 || hi > 32767.0) return image;
  ImageVolume out = image;
  out.pixel_type = PixelType::Int16;
  out.data.assign(image.voxelCount() * sizeof(std::int16_t), std::byte{0});
  auto* v = reinterpret_cast<std::int16_t*>(out.data.data());
  for (std::size_t i = 0; i < image.voxelCount(); ++i) v[i] = static_cast<std::int16_t>(image.valueAtIndex(i));
  return out;
}

/// Refuses what is not a CT in Hounsfield units, in the user's terms.
void checkIsCt(const io::ImageReadResult& read, const std::string& path, double lo, double hi, bool check_hu) {
  if (read.image.empty()) throw FormatError("import-ct: '" + path + "' holds no voxel");
  if (!read.modality.empty() && read.modality != "CT") {
    throw FormatError("import-ct: '" + path + "' is a " + read.modality + " series" +
                      (read.series_description.empty() ? "" : " (\"" + read.series_description + "\")") +
                      ", not a CT: choose the CT series (series=...; 'mrsns-cli info " + path +
                      "' lists the series of a folder)");
  }
  if (const auto labels = io::labelStatistics(read.image, 64); labels && lo >= 0.0) {
    throw FormatError("import-ct: '" + path + "' holds only " + std::to_string(labels->size()) +
                      " distinct non-negative integer values: it is a label map, not a CT. Import the CT first, "
                      "then this file with import-label-map");
  }
  if (check_hu && lo > -200.0) {
    std::ostringstream out;
    out << "import-ct: the values of '" << path << "' run from " << lo << " to " << hi
        << ", not Hounsfield units: a CT has air at about -1000 HU (is it an MR image, or a CT stored without its "
           "rescale slope and intercept?). Choose the CT; check_hu=false imports it anyway";
    throw FormatError(out.str());
  }
}

/// Whether `labels` lies on the CT's grid: the same size, spacing, origin and direction.
struct GridMatch {
  bool same_spacing = false, same_direction = false, same_size = false, same_origin = false;
  /// The label map's voxel (0,0,0) as a CT index, and whether that is a whole voxel.
  Eigen::Vector3d offset = Eigen::Vector3d::Zero();
  bool whole_voxel_offset = false;
  bool inside = false;  ///< a crop that lies within the CT's grid
};

GridMatch matchGrid(const ImageEntry& ct, const ImageVolume& labels) {
  GridMatch m;
  m.same_spacing = ((labels.spacing - ct.spacing_mm).array().abs() <= 1e-4 * ct.spacing_mm.array()).all();
  m.same_direction = (labels.direction - ct.direction).cwiseAbs().maxCoeff() <= 1e-4;
  m.same_size = labels.size == ct.size_px;
  const Eigen::Matrix3d ijk_to_lps = ct.direction * ct.spacing_mm.asDiagonal();
  m.offset = ijk_to_lps.inverse() * (labels.origin - ct.origin_mm);
  const Eigen::Vector3d rounded = m.offset.array().round();
  // A hundredth of a voxel: what float32 NIfTI headers and DICOM-to-NIfTI converters round to.
  m.whole_voxel_offset = ((m.offset - rounded).array().abs() <= 0.01).all();
  m.same_origin = m.whole_voxel_offset && rounded.isZero();
  m.inside = m.whole_voxel_offset;
  for (int a = 0; a < 3; ++a) {
    const double lo = rounded[a], hi = rounded[a] + labels.size[static_cast<std::size_t>(a)];
    if (lo < 0.0 || hi > ct.size_px[static_cast<std::size_t>(a)]) m.inside = false;
  }
  return m;
}

std::string geometryText(const std::array<int, 3>& size, const Eigen::Vector3d& spacing,
                         const Eigen::Vector3d& origin) {
  std::ostringstream out;
  out << size[0] << "x" << size[1] << "x" << size[2] << " voxels of " << vecText(spacing, 4) << " mm at "
      << vecText(origin, 2);
  return out.str();
}

/// `labels` copied into a volume on the CT's grid, at its whole-voxel offset.
ImageVolume embedInCtGrid(const ImageEntry& ct, const ImageVolume& labels, const Eigen::Vector3d& offset) {
  ImageVolume out;
  out.size = ct.size_px;
  out.spacing = ct.spacing_mm;
  out.origin = ct.origin_mm;
  out.direction = ct.direction;
  out.pixel_type = labels.pixel_type;
  out.frame = "CT";
  out.data.assign(out.byteCount(), std::byte{0});
  const std::size_t bytes = pixelTypeSize(labels.pixel_type);
  const int di = static_cast<int>(std::lround(offset.x())), dj = static_cast<int>(std::lround(offset.y())),
            dk = static_cast<int>(std::lround(offset.z()));
  const std::size_t row = static_cast<std::size_t>(labels.size[0]) * bytes;
  for (int k = 0; k < labels.size[2]; ++k) {
    for (int j = 0; j < labels.size[1]; ++j) {
      std::copy_n(labels.data.data() + labels.linearIndex(0, j, k) * bytes, row,
                  out.data.data() + out.linearIndex(di, j + dj, k + dk) * bytes);
    }
  }
  return out;
}

/// Nearest-neighbour resampling of `labels` onto the CT's grid (0 outside it).
ImageVolume resampleOntoCtGrid(const ImageEntry& ct, const ImageVolume& labels, std::size_t& covered) {
  ImageVolume out;
  out.size = ct.size_px;
  out.spacing = ct.spacing_mm;
  out.origin = ct.origin_mm;
  out.direction = ct.direction;
  out.pixel_type = labels.pixel_type;
  out.frame = "CT";
  out.data.assign(out.byteCount(), std::byte{0});
  const std::size_t bytes = pixelTypeSize(labels.pixel_type);
  const Eigen::Matrix3d ct_ijk_to_lps = ct.direction * ct.spacing_mm.asDiagonal();
  const Eigen::Matrix3d lps_to_label = (labels.direction * labels.spacing.asDiagonal()).inverse();
  const Eigen::Matrix3d step = lps_to_label * ct_ijk_to_lps;
  covered = 0;
  for (int k = 0; k < out.size[2]; ++k) {
    for (int j = 0; j < out.size[1]; ++j) {
      Eigen::Vector3d q = lps_to_label * (ct.origin_mm + ct_ijk_to_lps * Eigen::Vector3d(0, j, k) - labels.origin);
      for (int i = 0; i < out.size[0]; ++i, q += step.col(0)) {
        const int li = static_cast<int>(std::lround(q.x())), lj = static_cast<int>(std::lround(q.y())),
                  lk = static_cast<int>(std::lround(q.z()));
        if (!labels.contains(li, lj, lk)) continue;
        ++covered;
        std::copy_n(labels.data.data() + labels.linearIndex(li, lj, lk) * bytes, bytes,
                    out.data.data() + out.linearIndex(i, j, k) * bytes);
      }
    }
  }
  return out;
}

/// `labels` (on its own grid, with the CT's spacing and axes) placed at `offset` CT voxels; voxels shifted out of
/// the CT's grid are dropped.
ImageVolume shiftedIntoCtGrid(const ImageEntry& ct, const ImageVolume& labels, const Eigen::Vector3d& offset) {
  ImageVolume out;
  out.size = ct.size_px;
  out.spacing = ct.spacing_mm;
  out.origin = ct.origin_mm;
  out.direction = ct.direction;
  out.pixel_type = labels.pixel_type;
  out.data.assign(out.byteCount(), std::byte{0});
  const std::size_t bytes = pixelTypeSize(labels.pixel_type);
  const int di = static_cast<int>(std::lround(offset.x())), dj = static_cast<int>(std::lround(offset.y())),
            dk = static_cast<int>(std::lround(offset.z()));
  for (int k = 0; k < labels.size[2]; ++k) {
    for (int j = 0; j < labels.size[1]; ++j) {
      for (int i = 0; i < labels.size[0]; ++i) {
        if (!out.contains(i + di, j + dj, k + dk)) continue;
        std::copy_n(labels.data.data() + labels.linearIndex(i, j, k) * bytes, bytes,
                    out.data.data() + out.linearIndex(i + di, j + dj, k + dk) * bytes);
      }
    }
  }
  return out;
}

/// Centroid (voxel index) and count of each label value present in `wanted`.
std::map<int, std::pair<Eigen::Vector3d, std::size_t>> labelCentroids(const ImageVolume& labels,
                                                                       const std::set<int>& wanted) {
  std::map<int, std::pair<Eigen::Vector3d, std::size_t>> out;
  std::size_t index = 0;
  for (int k = 0; k < labels.size[2]; ++k) {
    for (int j = 0; j < labels.size[1]; ++j) {
      for (int i = 0; i < labels.size[0]; ++i, ++index) {
        const double v = labels.valueAtIndex(index);
        if (v == 0.0 || wanted.count(static_cast<int>(v)) == 0) continue;
        auto& [sum, n] = out[static_cast<int>(v)];
        if (n == 0) sum.setZero();
        sum += Eigen::Vector3d(i, j, k);
        ++n;
      }
    }
  }
  for (auto& [value, c] : out) c.first /= static_cast<double>(c.second);
  return out;
}

/// The vertebrae two label maps (both on the CT's grid) name alike: value in `a`, value in `b`.
std::vector<std::pair<int, int>> sharedVertebrae(const LabelMapEntry& a, const LabelMapEntry& b) {
  std::vector<std::pair<int, int>> shared;
  for (const auto& la : a.labels) {
    const std::string va = vertebraName(la.name);
    if (va.empty()) continue;
    for (const auto& lb : b.labels) {
      if (vertebraName(lb.name) == va) shared.emplace_back(la.value, lb.value);
    }
  }
  return shared;
}

/// The mean voxel shift that moves the new map's vertebrae onto the other map's (whole voxels); none when they
/// share no vertebra.
std::optional<Eigen::Vector3d> sharedLabelShift(const LabelMapEntry& entry, const ImageVolume& labels,
                                                const LabelMapEntry& other, const ImageVolume& other_labels) {
  const auto shared = sharedVertebrae(entry, other);
  if (shared.empty()) return std::nullopt;
  std::set<int> mine, theirs;
  for (const auto& [a, b] : shared) {
    mine.insert(a);
    theirs.insert(b);
  }
  const auto ca = labelCentroids(labels, mine);
  const auto cb = labelCentroids(other_labels, theirs);
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  int n = 0;
  for (const auto& [a, b] : shared) {
    const auto ia = ca.find(a);
    const auto ib = cb.find(b);
    if (ia == ca.end() || ib == cb.end()) continue;
    sum += ib->second.first - ia->second.first;
    ++n;
  }
  if (n == 0) return std::nullopt;
  return Eigen::Vector3d((sum / n).array().round() + 0.0);  // + 0.0: no "-0" in messages
}

/// Dice overlap of the shared vertebrae of two label maps on the CT's grid.
double sharedLabelDice(const LabelMapEntry& entry, const ImageVolume& labels, const LabelMapEntry& other,
                       const ImageVolume& other_labels) {
  std::map<int, int> pair;
  for (const auto& [a, b] : sharedVertebrae(entry, other)) pair[a] = b;
  std::size_t both = 0, in_a = 0, in_b = 0;
  std::set<int> theirs;
  for (const auto& [a, b] : pair) theirs.insert(b);
  for (std::size_t i = 0; i < labels.voxelCount(); ++i) {
    const int a = static_cast<int>(labels.valueAtIndex(i));
    const int b = static_cast<int>(other_labels.valueAtIndex(i));
    const auto it = pair.find(a);
    const bool mine = it != pair.end();
    if (mine) ++in_a;
    if (theirs.count(b) != 0) ++in_b;
    if (mine && it->second == b) ++both;
  }
  return in_a + in_b == 0 ? 0.0 : 2.0 * static_cast<double>(both) / static_cast<double>(in_a + in_b);
}

/// Mean CT value under each label (both on the CT's grid).
std::map<int, double> meanValueByLabel(const ImageVolume& ct, const ImageVolume& labels) {
  std::map<int, std::pair<double, std::size_t>> sums;
  for (std::size_t i = 0; i < labels.voxelCount(); ++i) {
    const double v = labels.valueAtIndex(i);
    if (v == 0.0) continue;
    auto& [sum, n] = sums[static_cast<int>(v)];
    sum += ct.valueAtIndex(i);
    ++n;
  }
  std::map<int, double> out;
  for (const auto& [value, s] : sums) out[value] = s.first / static_cast<double>(s.second);
  return out;
}

std::string stemOf(const fs::path& path) {
  std::string name = path.filename().string();
  for (const char* ext : {".nii.gz", ".nii", ".nrrd", ".nhdr", ".mha", ".mhd", ".seg.nrrd"}) {
    if (io::endsWith(io::lowerFileName(path), ext)) return name.substr(0, name.size() - std::string(ext).size());
  }
  return path.stem().string();
}

}  // namespace

StepResult runImportCt(Session& session, const Json& params, const StepContext& context) {
  const Params p("import-ct", params, {"path", "series", "name", "replace", "check_hu"});
  const std::string path = p.text("path", "");
  if (path.empty()) {
    throw InvalidArgumentError("import-ct: give path= the CT: a NIfTI, NRRD or MetaImage file, a DICOM file or a "
                               "DICOM series folder");
  }
  const bool replace = p.boolean("replace", false);
  if (const auto existing = session.ct()) {
    if (!replace) {
      throw InvalidArgumentError("import-ct: the session already has a CT ('" + existing->name + "', imported " +
                                 existing->provenance.time +
                                 "): start a new session for another patient, or pass replace=true (the label maps, "
                                 "models, fiducials and plan made on the old CT are then set aside)");
    }
    if (session.transform("CTToPatient")) {
      throw InvalidArgumentError("import-ct: the patient was registered to the session's CT ('" + existing->name +
                                 "'): a new CT needs a new session (the registration belongs to the old one)");
    }
  }
  const fs::path source(path);
  std::error_code ec;
  if (!fs::exists(source, ec)) {
    throw FileError("import-ct: '" + path + "' does not exist: give the CT's file or DICOM folder");
  }
  context.report(0.05, "reading " + source.filename().string());
  io::ImageReadOptions read_options;
  read_options.dicom_series = p.text("series", "");
  const io::ImageReadResult read = io::readImageFile(source, read_options);
  checkCancel(context);
  context.report(0.5, "checking that it is a CT");
  const auto [lo, hi] = valueRange(read.image);
  checkIsCt(read, path, lo, hi, p.boolean("check_hu", true));
  checkCancel(context);

  context.report(0.6, "storing it in the session");
  fs::create_directories(session.resolve("ct"));
  StepResult result;
  std::string stored;
  // One uncompressed NRRD whatever the user gave (the original stays where it is, named in the provenance):
  // the CT is read again by every later step and each time the session opens, and a 512 x 512 x 400 .nii.gz
  // takes over a second to decompress where the raw NRRD reads in a fraction of one.
  stored = freeSessionName(session, "ct", stemOf(source).empty() ? "CT" : stemOf(source), ".nrrd");
  io::ImageWriteOptions write;
  write.compress = false;
  const ImageVolume kept = narrowedToInt16(read.image, lo, hi);
  io::writeImage(kept, session.resolve(stored), write);
  result.outputs.push_back(stored);
  if (replace && session.ct()) {
    session.setAsidePatientData("import-ct replace=true: a new CT");
  }
  ImageEntry entry;
  entry.file = stored;
  entry.name = p.text("name", stemOf(source));
  entry.format = io::imageFormatName(read.format);
  entry.modality = read.modality.empty() ? "CT" : read.modality;
  entry.series_uid = read.series_uid;
  entry.series_description = read.series_description;
  entry.size_px = read.image.size;
  entry.spacing_mm = read.image.spacing;
  entry.origin_mm = read.image.origin;
  entry.direction = read.image.direction;
  entry.pixel_type = pixelTypeName(kept.pixel_type);
  entry.value_min = lo;
  entry.value_max = hi;
  entry.provenance = madeBy("import-ct", fs::absolute(source).string());
  Json& f = result.figures;
  f["size_px"] = entry.size_px;
  f["spacing_mm"] = {entry.spacing_mm.x(), entry.spacing_mm.y(), entry.spacing_mm.z()};
  f["origin_mm"] = {entry.origin_mm.x(), entry.origin_mm.y(), entry.origin_mm.z()};
  f["format"] = entry.format;
  f["modality"] = entry.modality;
  f["value_range_hu"] = {lo, hi};
  f["file"] = stored;
  if (read.format == io::ImageFormat::Dicom) {
    f["dicom_files"] = read.file_count;
    f["series_uid"] = read.series_uid;
    f["series_in_folder"] = read.series_in_folder;
    f["slice_gap_deviation_mm"] = read.slice_gap_deviation_mm;
    if (read.slice_gap_deviation_mm > 0.1 * read.image.spacing.z()) {
      f["warning"] = "slice gaps deviate by up to " + std::to_string(read.slice_gap_deviation_mm) +
                     " mm: slices may be missing";
    }
  }
  if (hi < 300.0) f["warning"] = "no voxel above 300 HU: this CT shows no bone";
  entry.provenance.quality = f;
  session.setCt(entry);
  result.ok = true;
  std::ostringstream summary;
  summary << "CT " << entry.name << ": " << geometryText(entry.size_px, entry.spacing_mm, entry.origin_mm) << ", "
          << lo << " to " << hi << " HU";
  result.summary = summary.str();
  return result;
}

StepResult runImportLabelMap(Session& session, const Json& params, const StepContext& context) {
  const Params p("import-label-map", params, {"path", "scheme", "name", "id", "resample", "align_to"});
  const std::string path = p.text("path", "");
  if (path.empty()) {
    throw InvalidArgumentError("import-label-map: give path= a label map on the session's CT (e.g. "
                               "TotalSegmentator's or VerSe's output: NIfTI, NRRD or MetaImage)");
  }
  const auto ct = session.ct();
  if (!ct) {
    throw InvalidArgumentError("import-label-map: the session has no CT: import the CT the labels were made on "
                               "first (import-ct)");
  }
  const fs::path source(path);
  context.report(0.05, "reading " + source.filename().string());
  ImageVolume labels = io::readImage(source);
  checkCancel(context);
  const auto stats = io::labelStatistics(labels, 1024);
  if (!stats) {
    throw FormatError("import-label-map: '" + path +
                      "' is not a label map: its voxels are not integers, or it holds more than 1024 distinct values "
                      "(is it the CT itself?)");
  }
  std::vector<io::LabelCount> present;
  for (const auto& s : *stats) {
    if (s.value < 0) {
      throw FormatError("import-label-map: '" + path + "' holds the negative value " + std::to_string(s.value) +
                        ": a label map numbers its structures from 1");
    }
    if (s.value != 0 && s.voxels > 0) present.push_back(s);
  }
  if (present.empty()) {
    throw FormatError("import-label-map: '" + path +
                      "' holds no label (every voxel is 0): the segmentation is empty; segment the CT again");
  }

  context.report(0.4, "placing it on the CT's grid");
  const ImageVolume as_read = labels;
  const GridMatch grid = matchGrid(*ct, labels);
  std::string placement;
  if (grid.same_spacing && grid.same_direction && grid.same_size && grid.same_origin) {
    placement = "same-grid";
  } else if (grid.same_spacing && grid.same_direction && grid.inside) {
    placement = "embedded";
    labels = embedInCtGrid(*ct, labels, grid.offset.array().round());
  } else {
    const Eigen::AlignedBox3d ct_box = ctBounds(*ct);
    ImageEntry as_entry;
    as_entry.size_px = labels.size;
    as_entry.spacing_mm = labels.spacing;
    as_entry.origin_mm = labels.origin;
    as_entry.direction = labels.direction;
    const Eigen::AlignedBox3d label_box = ctBounds(as_entry);
    const bool overlap = ct_box.intersects(label_box);
    const std::string geometry = "the label map is " +
                                 geometryText(labels.size, labels.spacing, labels.origin) + ", the CT " +
                                 geometryText(ct->size_px, ct->spacing_mm, ct->origin_mm);
    if (!overlap) {
      throw FormatError("import-label-map: '" + path + "' does not overlap the session's CT at all (" + geometry +
                        "): it was made on another image; segment this CT");
    }
    if (!p.boolean("resample", false)) {
      throw FormatError("import-label-map: the geometry of '" + path + "' does not match the session's CT (" +
                        geometry + (grid.same_direction ? "" : ", and their axes differ") +
                        "): give the label map made on this CT, or pass resample=true to resample it onto the CT "
                        "(nearest neighbour)");
    }
    std::size_t covered = 0;
    labels = resampleOntoCtGrid(*ct, labels, covered);
    placement = "resampled";
  }
  labels.frame = "CT";
  checkCancel(context);

  registration::LabelScheme scheme = registration::labelSchemeFromName(p.text("scheme", "auto"));
  std::vector<int> values;
  for (const auto& s : present) values.push_back(static_cast<int>(s.value));
  // A single-structure mask (0/1), as TotalSegmentator writes one per structure, is named after its file.
  const bool mask = values.size() == 1 && values[0] == 1 && scheme == registration::LabelScheme::Auto;
  if (scheme == registration::LabelScheme::Auto) {
    scheme = mask ? registration::LabelScheme::Generic : registration::detectLabelScheme(values);
  }
  LabelMapEntry entry;
  entry.id = p.text("id", "");
  if (entry.id.empty()) {
    const auto maps = session.labelMaps();
    entry.id = "labels";
    for (int n = 2; std::any_of(maps.begin(), maps.end(), [&](const auto& m) { return m.id == entry.id; }); ++n) {
      entry.id = "labels-" + std::to_string(n);
    }
  }
  entry.name = p.text("name", stemOf(source));
  entry.scheme = registration::labelSchemeName(scheme);
  entry.placement = placement;
  // The grid may have changed (embedded, resampled): count again on what is stored.
  const auto stored_stats = io::labelStatistics(labels, 1024);
  const double voxel_ml = labels.voxelVolume() / 1000.0;
  Json label_list = Json::array();
  for (const auto& s : *stored_stats) {
    if (s.value == 0 || s.voxels == 0) continue;
    LabelEntry l;
    l.value = static_cast<int>(s.value);
    l.name = mask ? stemOf(source) : registration::labelInfo(l.value, scheme).name;
    l.voxels = s.voxels;
    l.role = modelRoleName(structureRole(l.name));
    entry.labels.push_back(l);
    label_list.push_back({{"value", l.value},
                          {"name", l.name},
                          {"voxels", l.voxels},
                          {"volume_ml", static_cast<double>(l.voxels) * voxel_ml},
                          {"role", l.role}});
  }
  if (entry.labels.empty()) {
    throw FormatError("import-label-map: no label of '" + path +
                      "' falls inside the session's CT: it was made on another part of the body");
  }
  checkCancel(context);
  context.report(0.55, "checking the labels against the CT and the session's other label maps");
  Json consistency = Json::object();
  const std::string align_to = p.text("align_to", "");
  if (!align_to.empty()) {
    if (placement == "resampled") {
      throw InvalidArgumentError("import-label-map: align_to shifts a label map on the CT's own grid by whole "
                                 "voxels; it does not combine with resample=true");
    }
    const LabelMapEntry other = sessionLabelMap(session, align_to, "import-label-map");
    const ImageVolume other_labels = loadSessionLabelMap(session, other);
    const auto shift = sharedLabelShift(entry, labels, other, other_labels);
    if (!shift) {
      throw InvalidArgumentError("import-label-map: '" + path + "' and label map '" + align_to +
                                 "' share no vertebra label to align them by");
    }
    const Eigen::Vector3d header_offset =
        placement == "embedded" ? Eigen::Vector3d(grid.offset.array().round()) : Eigen::Vector3d::Zero();
    const Eigen::Vector3d at = header_offset + *shift;
    labels = shiftedIntoCtGrid(*ct, as_read, at);
    labels.frame = "CT";
    const double dice = sharedLabelDice(entry, labels, other, other_labels);
    if (dice < 0.7) {
      throw FormatError("import-label-map: shifted by whole voxels, the labels '" + path + "' shares with '" +
                        align_to + "' still overlap with a Dice of only " + std::to_string(dice) +
                        ": it is not a crop of this CT; segment this CT");
    }
    placement = "aligned";
    entry.placement = placement;
    consistency["aligned_to"] = align_to;
    consistency["shift_voxels"] = {shift->x(), shift->y(), shift->z()};
    consistency["shared_label_dice"] = dice;
    // The labels' counts do not change by a shift within the grid, save those shifted out.
    const auto shifted_stats = io::labelStatistics(labels, 1024);
    for (auto& l : entry.labels) {
      l.voxels = 0;
      for (const auto& st : *shifted_stats) {
        if (st.value == l.value) l.voxels = st.voxels;
      }
    }
  } else {
    // The same vertebra in two label maps of one CT lies at one place: a label map placed elsewhere has a header
    // that lies (a crop saved with the whole image's origin) or belongs to another image.
    for (const auto& other : session.labelMaps()) {
      const ImageVolume other_labels = loadSessionLabelMap(session, other);
      const auto shift = sharedLabelShift(entry, labels, other, other_labels);
      if (!shift) continue;
      const Eigen::Vector3d mm = ct->spacing_mm.cwiseProduct(*shift);
      if (mm.norm() > 2.0 * ct->spacing_mm.maxCoeff()) {
        std::ostringstream out;
        out.precision(1);
        out << std::fixed << "import-label-map: the vertebrae of '" << path << "' lie " << mm.norm()
            << " mm from the same vertebrae in label map '" << other.id << "' (" << shift->x() << ", " << shift->y()
            << ", " << shift->z()
            << " voxels): its header places it wrongly on the CT (a crop saved with the whole image's origin?). "
               "Give the label map made on this CT, or pass align_to="
            << other.id << " to shift it by whole voxels onto that label map's vertebrae";
        throw FormatError(out.str());
      }
    }
  }
  // Bone in a CT is dense: a vertebra label on fat or air was put on another image, or misplaced.
  {
    const ImageVolume image = loadSessionCt(session, "import-label-map");
    const auto means = meanValueByLabel(image, labels);
    Json hu = Json::object();
    std::vector<std::string> off;
    for (const auto& l : entry.labels) {
      const auto it = means.find(l.value);
      if (it == means.end()) continue;
      if (l.role == "bone") {
        hu[l.name] = it->second;
        if (it->second < 0.0) off.push_back(l.name);
      }
    }
    if (!hu.empty()) consistency["bone_mean_hu"] = hu;
    if (!off.empty()) {
      std::string names;
      for (const auto& n : off) names += (names.empty() ? "" : ", ") + n;
      throw FormatError("import-label-map: the bone labels " + names + " of '" + path +
                        "' lie on voxels averaging below 0 HU (fat, soft tissue or air, not bone): the label map "
                        "is not placed on this CT; give the label map made on it");
    }
  }
  context.report(0.7, "storing it in the session");
  entry.file = freeSessionName(session, "labels", entry.id, ".nrrd");
  io::writeImage(labels, session.resolve(entry.file));
  entry.provenance = madeBy("import-label-map", fs::absolute(source).string());
  StepResult result;
  result.outputs.push_back(entry.file);
  result.figures["id"] = entry.id;
  result.figures["scheme"] = entry.scheme;
  result.figures["placement"] = placement;
  result.figures["labels"] = label_list;
  if (!consistency.empty()) result.figures["checks"] = consistency;
  result.figures["file"] = entry.file;
  entry.provenance.quality = {{"placement", placement}, {"labels", entry.labels.size()}};
  session.putLabelMap(entry);
  result.ok = true;
  result.summary = "label map " + entry.id + " (" + entry.scheme + "): " + std::to_string(entry.labels.size()) +
                   " labels, " + placement;
  return result;
}

}  // namespace mrsns::workflow::detail
