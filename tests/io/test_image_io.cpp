#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <unistd.h>
#include <zlib.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <random>
#include <sstream>

#include "cli_runner.h"
#include "mrsns/core/error.h"
#include "mrsns/io/image_io.h"
#include "required_tool.h"
#include "test_data.h"

namespace mrsns::io {
namespace {

using ::mrsns::test::writeBytes;

using ::testing::HasSubstr;

template <typename T>
ImageVolume syntheticVolume(PixelType type) {
  ImageVolume v;
  v.size = {7, 5, 4};
  v.spacing = Eigen::Vector3d(0.7, 1.3, 2.5);
  v.origin = Eigen::Vector3d(-120.25, 33.5, 871.0);
  // An oblique, right-handed direction (rotation about an arbitrary axis).
  v.direction = Eigen::AngleAxisd(0.4, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix();
  v.pixel_type = type;
  v.data.resize(v.byteCount());
  std::mt19937 rng(42);
  for (std::size_t i = 0; i < v.voxelCount(); ++i) {
    const T value = static_cast<T>(static_cast<int>(rng() % 200) - (std::is_signed_v<T> ? 100 : 0)) / T(1);
    std::memcpy(v.data.data() + i * sizeof(T), &value, sizeof(T));
  }
  return v;
}

std::vector<ImageVolume> allPixelTypes() {
  return {syntheticVolume<std::uint8_t>(PixelType::UInt8),   syntheticVolume<std::int8_t>(PixelType::Int8),
          syntheticVolume<std::uint16_t>(PixelType::UInt16), syntheticVolume<std::int16_t>(PixelType::Int16),
          syntheticVolume<std::uint32_t>(PixelType::UInt32), syntheticVolume<std::int32_t>(PixelType::Int32),
          syntheticVolume<float>(PixelType::Float32),        syntheticVolume<double>(PixelType::Float64)};
}

std::string slurp(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

void expectSameGeometry(const ImageVolume& a, const ImageVolume& b, double tolerance) {
  EXPECT_EQ(a.size, b.size);
  EXPECT_LT((a.spacing - b.spacing).cwiseAbs().maxCoeff(), tolerance);
  EXPECT_LT((a.origin - b.origin).cwiseAbs().maxCoeff(), tolerance);
  EXPECT_LT((a.direction - b.direction).cwiseAbs().maxCoeff(), tolerance);
}

TEST(ImageIo, RoundTripEveryFormatAndPixelType) {
  const auto dir = test::scratchDirectory("img");
  for (const std::string ext : {".nrrd", ".nhdr", ".nii", ".nii.gz", ".mha", ".mhd"}) {
    for (const ImageVolume& volume : allPixelTypes()) {
      SCOPED_TRACE(ext + " " + pixelTypeName(volume.pixel_type));
      const auto file = dir / (pixelTypeName(volume.pixel_type) + ext);
      writeImage(volume, file);
      const ImageVolume back = readImage(file);
      EXPECT_EQ(back.pixel_type, volume.pixel_type);
      // NIfTI stores geometry as float32 (relative precision 6e-8, values up to ~900 mm).
      expectSameGeometry(volume, back, ext.find(".nii") != std::string::npos ? 1e-4 : 1e-9);
      EXPECT_TRUE(back.data == volume.data);
    }
  }
}

TEST(ImageIo, VoxelIndexAndPhysicalPointsAreInverse) {
  const ImageVolume v = syntheticVolume<std::int16_t>(PixelType::Int16);
  const Eigen::Vector3d ijk(2.5, -1.0, 3.25);
  const Eigen::Vector3d p = v.indexToPhysical(ijk);
  EXPECT_LT((v.physicalToIndex(p) - ijk).norm(), 1e-12);
  EXPECT_LT((v.ijkToLps() * ijk.homogeneous() - p.homogeneous()).norm(), 1e-12);
  // One step along i moves spacing[0] mm along direction column 0.
  EXPECT_LT((v.indexToPhysical(Eigen::Vector3d(1, 0, 0)) - v.origin - 0.7 * v.direction.col(0)).norm(), 1e-12);
  std::int16_t raw;
  std::memcpy(&raw, v.data.data() + v.linearIndex(3, 2, 1) * 2, 2);
  EXPECT_EQ(v.value(3, 2, 1), raw);
}

TEST(ImageIo, DicomSeriesJpeg2000GeometryAndNrrdRoundTrip) {
  MRSNS_REQUIRE_DATA(folder, "ct/totalsegmentator/example_ct_dicom");
  const ImageReadResult read = readImageFile(folder);
  const ImageVolume& ct = read.image;
  EXPECT_EQ(read.format, ImageFormat::Dicom);
  EXPECT_EQ(read.file_count, 20U);
  // From the headers (gdcmdump): 512x512 slices, PixelSpacing 0.9765625, axial
  // orientation 1\0\0\0\1\0, ImagePositionPatient z from -804.5 to -766.5 (20 slices: 2 mm).
  EXPECT_EQ(ct.size, (std::array<int, 3>{512, 512, 20}));
  EXPECT_DOUBLE_EQ(ct.spacing.x(), 0.9765625);
  EXPECT_DOUBLE_EQ(ct.spacing.y(), 0.9765625);
  EXPECT_NEAR(ct.spacing.z(), 2.0, 1e-9);
  EXPECT_LT((ct.origin - Eigen::Vector3d(-249.51171875, -437.51171875, -804.5)).norm(), 1e-6);
  EXPECT_LT((ct.direction - Eigen::Matrix3d::Identity()).norm(), 1e-9);
  EXPECT_LT(read.slice_gap_deviation_mm, 1e-6);
  // Rescale intercept -1024 applied: air near -1000 HU, nothing below -1024 + tolerance for padding.
  double lo = 1e9, hi = -1e9;
  for (std::size_t i = 0; i < ct.voxelCount(); i += 97) {
    lo = std::min(lo, ct.valueAtIndex(i));
    hi = std::max(hi, ct.valueAtIndex(i));
  }
  EXPECT_GE(lo, -3024.0);
  EXPECT_LE(lo, -900.0);
  EXPECT_GT(hi, 200.0);  // bone is present
  EXPECT_FALSE(labelStatistics(ct).has_value());

  const auto dir = test::scratchDirectory("img");
  writeImage(ct, dir / "ct.nrrd");
  const ImageVolume back = readImage(dir / "ct.nrrd");
  expectSameGeometry(ct, back, 1e-9);
  EXPECT_EQ(back.pixel_type, ct.pixel_type);
  EXPECT_TRUE(back.data == ct.data);
}

TEST(ImageIo, DicomSeriesWithATruncatedSliceIsAFormatError) {
  MRSNS_REQUIRE_DATA(folder, "ct/totalsegmentator/example_ct_dicom");
  // A scratch copy (under the build tree) with one JPEG 2000 slice cut short.
  const auto dir = test::scratchDirectory("img") / "series";
  std::filesystem::create_directories(dir);
  std::vector<std::filesystem::path> slices;
  for (const auto& entry : std::filesystem::directory_iterator(folder)) slices.push_back(entry.path());
  std::sort(slices.begin(), slices.end());
  ASSERT_EQ(slices.size(), 20U);
  for (const auto& s : slices) std::filesystem::copy_file(s, dir / s.filename());
  const auto victim = dir / slices[7].filename();
  const std::string bytes = slurp(victim);
  writeBytes(victim, bytes.substr(0, bytes.size() * 2 / 3));
  try {
    (void)readImage(dir);
    FAIL() << "a series with a truncated slice was accepted";
  } catch (const FormatError& e) {
    EXPECT_THAT(e.what(), HasSubstr(dir.string()));
  }
}

TEST(ImageIo, SingleDicomFile) {
  MRSNS_REQUIRE_DATA(file, "ct/nema/CT_small.dcm");
  const ImageReadResult read = readImageFile(file);
  EXPECT_EQ(read.format, ImageFormat::Dicom);
  EXPECT_EQ(read.image.size[2], 1);
  EXPECT_EQ(read.image.size[0], 128);
  EXPECT_EQ(read.image.size[1], 128);
  EXPECT_GT(read.image.spacing.x(), 0.0);
  EXPECT_NEAR(std::abs(read.image.direction.determinant()), 1.0, 1e-6);
}

/// The geometry a NIfTI-1 header declares, converted RAS -> LPS by hand
/// (what nibabel's affine gives, with x and y negated), read from the raw bytes.
struct NiftiHeaderGeometry {
  std::array<int, 3> size{};
  Eigen::Vector3d spacing;
  Eigen::Vector3d origin_lps;
  Eigen::Matrix3d direction_lps;
  short qform_code = 0, sform_code = 0;
};

NiftiHeaderGeometry niftiHeaderGeometry(const std::filesystem::path& path) {
  gzFile gz = gzopen(path.string().c_str(), "rb");
  EXPECT_NE(gz, nullptr);
  unsigned char h[348] = {};
  EXPECT_EQ(gzread(gz, h, sizeof h), 348);
  gzclose(gz);
  auto i32 = [&](int at) {
    std::int32_t v;
    std::memcpy(&v, h + at, 4);
    return v;
  };
  auto i16 = [&](int at) {
    std::int16_t v;
    std::memcpy(&v, h + at, 2);
    return v;
  };
  auto f32 = [&](int at) {
    float v;
    std::memcpy(&v, h + at, 4);
    return static_cast<double>(v);
  };
  EXPECT_EQ(i32(0), 348) << "not a little-endian NIfTI-1 header";
  NiftiHeaderGeometry g;
  for (int a = 0; a < 3; ++a) g.size[static_cast<std::size_t>(a)] = i16(42 + 2 * a);
  g.spacing = Eigen::Vector3d(f32(80), f32(84), f32(88));
  g.qform_code = i16(252);
  g.sform_code = i16(254);
  const Eigen::Matrix3d flip = Eigen::Vector3d(-1, -1, 1).asDiagonal();
  Eigen::Matrix3d dir_ras;
  Eigen::Vector3d origin_ras;
  if (g.sform_code > 0) {
    Eigen::Matrix3d a;
    for (int r = 0; r < 3; ++r) {
      for (int c = 0; c < 3; ++c) a(r, c) = f32(280 + 16 * r + 4 * c);
      origin_ras[r] = f32(280 + 16 * r + 12);
    }
    dir_ras = a * g.spacing.cwiseInverse().asDiagonal();
  } else {
    const double b = f32(256), c = f32(260), d = f32(264);
    const double a = std::sqrt(std::max(0.0, 1.0 - (b * b + c * c + d * d)));
    dir_ras << a * a + b * b - c * c - d * d, 2 * (b * c - a * d), 2 * (b * d + a * c),  //
        2 * (b * c + a * d), a * a + c * c - b * b - d * d, 2 * (c * d - a * b),         //
        2 * (b * d - a * c), 2 * (c * d + a * b), a * a + d * d - c * c - b * b;
    const double qfac = f32(76) < 0 ? -1.0 : 1.0;
    dir_ras.col(2) *= qfac;
    origin_ras = Eigen::Vector3d(f32(268), f32(272), f32(276));
  }
  g.direction_lps = flip * dir_ras;
  g.origin_lps = flip * origin_ras;
  return g;
}

TEST(ImageIo, NiftiLabelMapsMatchTheirHeaderGeometryInLps) {
  const std::vector<std::string> maps = {"ct/totalsegmentator/example_seg.nii.gz",
                                         "ct/totalsegmentator/spine_report/example_ct_report/totalseg.nii.gz",
                                         "ct/verse/sub-verse004_seg-vert_msk.nii.gz",
                                         "ct/totalsegmentator/aorta_report/test_result/models/vertebrae_T12.nii.gz"};
  int checked = 0;
  for (const auto& relative : maps) {
    const auto path = findDataFile(relative);
    if (!path) {
      // Under CI every map must be there; elsewhere the ones present are checked.
      EXPECT_FALSE(test::missingDataFails()) << test::missingDataMessage(relative);
      continue;
    }
    SCOPED_TRACE(relative);
    const NiftiHeaderGeometry expected = niftiHeaderGeometry(*path);
    ASSERT_TRUE(expected.sform_code > 0 || expected.qform_code > 0);
    const ImageVolume image = readImage(*path);
    EXPECT_EQ(image.size, expected.size);
    EXPECT_LT((image.spacing - expected.spacing.cwiseAbs()).cwiseAbs().maxCoeff(), 1e-5);
    // float32 header values: origins up to ~1000 mm carry ~1e-4 mm of rounding.
    EXPECT_LT((image.origin - expected.origin_lps).cwiseAbs().maxCoeff(), 1e-3);
    EXPECT_LT((image.direction - expected.direction_lps).cwiseAbs().maxCoeff(), 1e-4);
    const auto labels = labelStatistics(image);
    ASSERT_TRUE(labels.has_value());
    std::size_t total = 0;
    for (const auto& l : *labels) total += l.voxels;
    EXPECT_EQ(total, image.voxelCount());
    ++checked;
  }
  if (checked == 0 && !test::missingDataFails()) GTEST_SKIP() << "no NIfTI label maps in the data directory";
}

TEST(ImageIo, VerseLabelMapHoldsT9ToL5) {
  MRSNS_REQUIRE_DATA(path, "ct/verse/sub-verse004_seg-vert_msk.nii.gz");
  const ImageVolume image = readImage(path);
  EXPECT_NEAR(image.spacing.minCoeff(), 1.0, 1e-3);
  EXPECT_NEAR(image.spacing.maxCoeff(), 2.0, 1e-3);
  const auto labels = labelStatistics(image);
  ASSERT_TRUE(labels.has_value());
  std::vector<std::int64_t> values;
  for (const auto& l : *labels) values.push_back(l.value);
  EXPECT_EQ(values, (std::vector<std::int64_t>{0, 16, 17, 18, 19, 20, 21, 22, 23, 24}));
  for (const auto& l : *labels) {
    if (l.value == 0) continue;
    // A vertebra is some 20-120 ml.
    const double ml = static_cast<double>(l.voxels) * image.voxelVolume() / 1000.0;
    EXPECT_GT(ml, 10.0) << l.value;
    EXPECT_LT(ml, 200.0) << l.value;
  }
}

TEST(ImageIo, TotalSegmentatorSpineLabels) {
  MRSNS_REQUIRE_DATA(path, "ct/totalsegmentator/spine_report/example_ct_report/totalseg.nii.gz");
  const ImageVolume image = readImage(path);
  EXPECT_EQ(image.pixel_type, PixelType::UInt8);
  EXPECT_EQ(image.size, (std::array<int, 3>{122, 101, 112}));
  const auto labels = labelStatistics(image);
  ASSERT_TRUE(labels.has_value());
  // Counted independently from the raw bytes (a Python script over the
  // decompressed file): labels 26-33 (S1 ... T11 in TotalSegmentator v2);
  // label 31 (L1) has 2143 voxels of 27 mm^3 = 57.86 ml.
  std::vector<std::int64_t> values;
  for (const auto& l : *labels) values.push_back(l.value);
  EXPECT_EQ(values, (std::vector<std::int64_t>{0, 26, 27, 28, 29, 30, 31, 32, 33}));
  for (const auto& l : *labels) {
    if (l.value == 31) {
      EXPECT_EQ(l.voxels, 2143U);
      EXPECT_NEAR(static_cast<double>(l.voxels) * image.voxelVolume() / 1000.0, 57.86, 0.005);
    }
  }
}

TEST(ImageIo, LabelStatisticsCountsAndRefusesContinuousImages) {
  ImageVolume v;
  v.size = {4, 3, 2};
  v.pixel_type = PixelType::Int32;
  std::vector<std::int32_t> values = {0, 0, 0, 5, 5, -3, 1000000, 0, 0, 0, 0, 0, 5, 5, 5, 0, 0, 0, 0, 0, 0, 0, 0, -3};
  v.data.resize(values.size() * 4);
  std::memcpy(v.data.data(), values.data(), v.data.size());
  const auto labels = labelStatistics(v);
  ASSERT_TRUE(labels.has_value());
  ASSERT_EQ(labels->size(), 4U);
  EXPECT_EQ((*labels)[0].value, -3);
  EXPECT_EQ((*labels)[0].voxels, 2U);
  EXPECT_EQ((*labels)[1].voxels, 16U);
  EXPECT_EQ((*labels)[2].voxels, 5U);
  EXPECT_EQ((*labels)[3].value, 1000000);
  EXPECT_FALSE(labelStatistics(v, 3).has_value());
  ImageVolume f = syntheticVolume<float>(PixelType::Float32);
  const float half = 0.5F;
  std::memcpy(f.data.data(), &half, 4);
  EXPECT_FALSE(labelStatistics(f).has_value());
}

template <typename E>
void expectErrorNaming(const std::filesystem::path& path) {
  try {
    (void)readImage(path);
    ADD_FAILURE() << path << " was accepted";
  } catch (const E& e) {
    EXPECT_THAT(e.what(), HasSubstr(path.filename().string()));
  } catch (const std::exception& e) {
    ADD_FAILURE() << "wrong exception type for " << path << ": " << e.what();
  }
}

TEST(ImageIo, NrrdShorterThanItsHeaderIsAFormatError) {
  const auto dir = test::scratchDirectory("img");
  writeBytes(dir / "short.nrrd",
             "NRRD0004\ntype: uint8\ndimension: 3\nsizes: 10 10 10\nencoding: raw\n\n" + std::string(500, '\x07'));
  expectErrorNaming<FormatError>(dir / "short.nrrd");
  writeBytes(dir / "garbage.nrrd", "definitely not an image");
  expectErrorNaming<FormatError>(dir / "garbage.nrrd");
}

TEST(ImageIo, TruncatedNiftiIsAFormatError) {
  const auto dir = test::scratchDirectory("img");
  const ImageVolume v = syntheticVolume<std::int16_t>(PixelType::Int16);
  writeImage(v, dir / "full.nii", {.compress = false});
  const std::string bytes = slurp(dir / "full.nii");
  writeBytes(dir / "cut.nii", bytes.substr(0, bytes.size() - 100));
  expectErrorNaming<FormatError>(dir / "cut.nii");
  writeBytes(dir / "header_only.nii", bytes.substr(0, 200));
  expectErrorNaming<FormatError>(dir / "header_only.nii");
  writeImage(v, dir / "full.nii.gz");
  const std::string gz = slurp(dir / "full.nii.gz");
  writeBytes(dir / "cut.nii.gz", gz.substr(0, gz.size() / 2));
  expectErrorNaming<FormatError>(dir / "cut.nii.gz");
  // Damaged inside with its trailer intact (the length the gzip trailer records still matches the header): the
  // decompression itself must refuse it, not hand back a volume.
  std::string damaged = gz;
  for (std::size_t i = damaged.size() / 3; i < damaged.size() / 3 + 64; ++i) damaged[i] = static_cast<char>(~damaged[i]);
  writeBytes(dir / "damaged.nii.gz", damaged);
  expectErrorNaming<FormatError>(dir / "damaged.nii.gz");
}

TEST(ImageIo, TruncatedMetaImageIsAFormatError) {
  const auto dir = test::scratchDirectory("img");
  const ImageVolume v = syntheticVolume<std::int16_t>(PixelType::Int16);
  for (bool compress : {false, true}) {
    const std::string stem = compress ? "z" : "raw";
    writeImage(v, dir / (stem + ".mha"), {.compress = compress});
    const std::string bytes = slurp(dir / (stem + ".mha"));
    writeBytes(dir / (stem + "_cut.mha"), bytes.substr(0, bytes.size() - 40));
    expectErrorNaming<FormatError>(dir / (stem + "_cut.mha"));
  }
  // A detached header whose data file lost its tail.
  writeImage(v, dir / "split.mhd", {.compress = false});
  const std::string raw = slurp(dir / "split.raw");
  ASSERT_EQ(raw.size(), v.byteCount());
  writeBytes(dir / "split.raw", raw.substr(0, raw.size() / 2));
  expectErrorNaming<FormatError>(dir / "split.mhd");
}

TEST(ImageIo, MissingUnsupportedAndInvalidVolumes) {
  const auto dir = test::scratchDirectory("img");
  expectErrorNaming<FileError>(dir / "missing.nrrd");
  writeBytes(dir / "picture.png", "png?");
  expectErrorNaming<UnsupportedError>(dir / "picture.png");
  ImageVolume v = syntheticVolume<std::uint8_t>(PixelType::UInt8);
  v.data.pop_back();
  EXPECT_THROW(writeImage(v, dir / "bad.nrrd"), InvalidArgumentError);
  v = syntheticVolume<std::uint8_t>(PixelType::UInt8);
  v.spacing.x() = 0.0;
  EXPECT_THROW(writeImage(v, dir / "bad.nrrd"), InvalidArgumentError);
  EXPECT_THROW(writeImage(syntheticVolume<std::uint8_t>(PixelType::UInt8), dir / "x.png"), UnsupportedError);
  EXPECT_THROW(writeImage(syntheticVolume<std::uint8_t>(PixelType::UInt8), dir / "nofolder" / "x.nrrd"), FileError);
}

// ---- DICOM series: listing, choice, modality; dcm2niix as a peer ----

/// The slice files of a series folder, sorted.
std::vector<std::filesystem::path> dicomSliceFiles(const std::filesystem::path& folder) {
  std::vector<std::filesystem::path> files;
  for (const auto& entry : std::filesystem::directory_iterator(folder)) files.push_back(entry.path());
  std::sort(files.begin(), files.end());
  return files;
}

/// `gdcmanon --dumb --replace TAG=VALUE ... -i in -o out` (the header rewritten, pixel data kept as stored).
void dicomRewrite(const std::filesystem::path& gdcmanon, const std::filesystem::path& in,
                  const std::filesystem::path& out, const std::vector<std::string>& replacements) {
  std::vector<std::string> args = {"--dumb"};
  for (const auto& r : replacements) {
    args.push_back("--replace");
    args.push_back(r);
  }
  for (const std::string& a : {std::string("-i"), in.string(), std::string("-o"), out.string()}) args.push_back(a);
  const auto result = test::runProgram(gdcmanon, args);
  ASSERT_EQ(result.exit_code, 0) << "gdcmanon failed on " << in << ": " << result.out << result.err;
}

void expectSameVolume(const ImageReadResult& a, const ImageReadResult& b) {
  expectSameGeometry(a.image, b.image, 1e-12);
  EXPECT_EQ(a.image.pixel_type, b.image.pixel_type);
  EXPECT_TRUE(a.image.data == b.image.data);
  EXPECT_EQ(a.series_uid, b.series_uid);
  EXPECT_EQ(a.file_count, b.file_count);
}

TEST(ImageIoDicomSeries, TheSharedSeriesIsListedWithItsTagsAndReadByUidOrIndex) {
  MRSNS_REQUIRE_DATA(folder, "ct/totalsegmentator/example_ct_dicom");
  const std::vector<DicomSeriesInfo> series = listDicomSeries(folder);
  ASSERT_EQ(series.size(), 1U);
  const DicomSeriesInfo& s = series.front();
  // The headers (gdcmdump): Modality CT, SeriesDescription "CT Body 3.0", StudyDate 20221208, BodyPartExamined
  // PARTIALBODY, 512 x 512; the data set was anonymised: SeriesInstanceUID, SeriesNumber and PatientID are empty.
  EXPECT_EQ(s.modality, "CT");
  EXPECT_EQ(s.files, 20U);
  EXPECT_EQ(s.rows, 512);
  EXPECT_EQ(s.columns, 512);
  EXPECT_EQ(s.description, "CT Body 3.0");
  EXPECT_EQ(s.study_date, "20221208");
  EXPECT_EQ(s.body_part, "PARTIALBODY");
  EXPECT_EQ(s.series_instance_uid, "");
  EXPECT_EQ(s.series_number, "");
  EXPECT_EQ(s.patient_id, "");
  EXPECT_FALSE(s.uid.empty());

  const ImageReadResult read = readImageFile(folder);
  EXPECT_EQ(read.modality, "CT");
  EXPECT_EQ(read.series_description, "CT Body 3.0");
  EXPECT_EQ(read.study_date, "20221208");
  EXPECT_EQ(read.series_uid, s.uid);
  EXPECT_EQ(read.series_in_folder, 1U);
  const ImageReadResult by_uid = readImageFile(folder, ImageReadOptions{s.uid});
  const ImageReadResult by_index = readImageFile(folder, ImageReadOptions{"1"});
  expectSameVolume(by_uid, read);
  expectSameVolume(by_index, read);
  EXPECT_EQ(by_index.modality, "CT");
}

TEST(ImageIoDicomSeries, AnUnknownSeriesIsRefusedNamingTheSeriesThere) {
  MRSNS_REQUIRE_DATA(folder, "ct/totalsegmentator/example_ct_dicom");
  for (const std::string choice : {"2", "0", "1.2.840.99999.1", "CT Body 3.0"}) {
    SCOPED_TRACE(choice);
    try {
      (void)readImageFile(folder, ImageReadOptions{choice});
      ADD_FAILURE() << "series '" << choice << "' was accepted";
    } catch (const InvalidArgumentError& e) {
      EXPECT_THAT(e.what(), HasSubstr(folder.string()));
      EXPECT_THAT(e.what(), HasSubstr("'" + choice + "'"));
      EXPECT_THAT(e.what(), HasSubstr("1: series (no number), CT \"CT Body 3.0\", 20 files"));
      EXPECT_THAT(e.what(), HasSubstr("index (1 to 1)"));
    }
  }
  MRSNS_REQUIRE_DATA(file, "ct/nema/CT_small.dcm");
  // A series is chosen in a folder only.
  EXPECT_THROW((void)readImageFile(file, ImageReadOptions{"1"}), InvalidArgumentError);
  EXPECT_THROW((void)listDicomSeries(file), FileError);
  EXPECT_THROW((void)listDicomSeries(folder / "missing"), FileError);
  const auto empty = test::scratchDirectory("empty");
  EXPECT_TRUE(listDicomSeries(empty).empty());
  try {
    (void)readImageFile(empty);
    FAIL() << "an empty folder was read";
  } catch (const FormatError& e) {
    EXPECT_THAT(e.what(), HasSubstr("no DICOM image series"));
  }
}

TEST(ImageIoDicomSeries, AFolderWithTwoSeriesListsBothAndReadsEachByChoice) {
  MRSNS_REQUIRE_DATA(folder, "ct/totalsegmentator/example_ct_dicom");
  MRSNS_REQUIRE_DATA(small, "ct/nema/CT_small.dcm");
  const auto dir = test::scratchDirectory("two-series");
  for (const auto& f : dicomSliceFiles(folder)) std::filesystem::copy_file(f, dir / f.filename());
  std::filesystem::copy_file(small, dir / "CT_small.dcm");
  const std::vector<DicomSeriesInfo> series = listDicomSeries(dir);
  ASSERT_EQ(series.size(), 2U);
  // Largest first.
  EXPECT_EQ(series[0].files, 20U);
  EXPECT_EQ(series[0].description, "CT Body 3.0");
  // CT_small.dcm (gdcmdump): SeriesInstanceUID 1.3.6.1.4.1.5962.1.3.1.1.20040119072730.12322, SeriesNumber 1,
  // 128 x 128, StudyDate 20040119, PatientID 1CT1.
  const DicomSeriesInfo& nema = series[1];
  EXPECT_EQ(nema.files, 1U);
  EXPECT_EQ(nema.modality, "CT");
  EXPECT_EQ(nema.series_instance_uid, "1.3.6.1.4.1.5962.1.3.1.1.20040119072730.12322");
  EXPECT_EQ(nema.series_number, "1");
  EXPECT_EQ(nema.rows, 128);
  EXPECT_EQ(nema.columns, 128);
  EXPECT_EQ(nema.study_date, "20040119");
  EXPECT_EQ(nema.patient_id, "1CT1");
  EXPECT_NE(nema.uid, series[0].uid);

  // No choice: the largest, as before (with a warning).
  const ImageReadResult shared = readImageFile(folder);
  const ImageReadResult largest = readImageFile(dir);
  EXPECT_EQ(largest.series_in_folder, 2U);
  EXPECT_EQ(largest.file_count, 20U);
  expectSameGeometry(largest.image, shared.image, 1e-12);
  EXPECT_TRUE(largest.image.data == shared.image.data);
  EXPECT_TRUE(readImageFile(dir, ImageReadOptions{series[0].uid}).image.data == shared.image.data);

  // The NEMA slice by its index, its uid and its SeriesInstanceUID: the same as reading the file alone.
  const ImageReadResult alone = readImageFile(small);
  EXPECT_EQ(alone.modality, "CT");
  EXPECT_EQ(alone.series_instance_uid, nema.series_instance_uid);
  EXPECT_EQ(alone.patient_id, "1CT1");
  for (const std::string& choice : {std::string("2"), nema.uid, nema.series_instance_uid}) {
    SCOPED_TRACE(choice);
    const ImageReadResult chosen = readImageFile(dir, ImageReadOptions{choice});
    EXPECT_EQ(chosen.file_count, 1U);
    EXPECT_EQ(chosen.series_uid, nema.uid);
    EXPECT_EQ(chosen.series_instance_uid, nema.series_instance_uid);
    EXPECT_EQ(chosen.study_date, "20040119");
    expectSameGeometry(chosen.image, alone.image, 1e-12);
    EXPECT_TRUE(chosen.image.data == alone.image.data);
  }
  try {
    (void)readImageFile(dir, ImageReadOptions{"3"});
    FAIL() << "a third series was read";
  } catch (const InvalidArgumentError& e) {
    EXPECT_THAT(e.what(), HasSubstr("1: series (no number), CT \"CT Body 3.0\", 20 files"));
    EXPECT_THAT(e.what(), HasSubstr("2: series 1, CT, 1 file"));
  }
}

TEST(ImageIoDicomSeries, ASeriesChosenBySeriesInstanceUidAndAnMrSeriesBeside) {
  MRSNS_REQUIRE_DATA(folder, "ct/totalsegmentator/example_ct_dicom");
  MRSNS_REQUIRE_DATA(small, "ct/nema/CT_small.dcm");
  MRSNS_REQUIRE_TOOL(gdcmanon, "gdcmanon");
  // The shared series with a SeriesInstanceUID (and the SOP instance UIDs a writer needs) stamped into its
  // headers, beside an MR series: the NEMA slice relabelled as MR Image Storage.
  const auto dir = test::scratchDirectory("ct-and-mr");
  const std::string ct_uid = "1.2.826.0.1.3680043.8.498.77001";
  int n = 0;
  for (const auto& f : dicomSliceFiles(folder)) {
    ++n;
    dicomRewrite(gdcmanon, f, dir / f.filename(),
                 {"0020,000e=" + ct_uid, "0008,0016=1.2.840.10008.5.1.4.1.1.2",
                  "0008,0018=" + ct_uid + "." + std::to_string(n), "0020,0011=7"});
  }
  const std::string mr_uid = "1.2.826.0.1.3680043.8.498.77002";
  dicomRewrite(gdcmanon, small, dir / "mr.dcm",
               {"0008,0060=MR", "0008,0016=1.2.840.10008.5.1.4.1.1.4", "0020,000e=" + mr_uid, "0008,103e=T1 axial",
                "0020,0011=3"});
  if (HasFailure()) return;
  const std::vector<DicomSeriesInfo> series = listDicomSeries(dir);
  ASSERT_EQ(series.size(), 2U);
  EXPECT_EQ(series[0].series_instance_uid, ct_uid);
  EXPECT_EQ(series[0].series_number, "7");
  EXPECT_EQ(series[0].files, 20U);
  EXPECT_EQ(series[1].modality, "MR");
  EXPECT_EQ(series[1].description, "T1 axial");
  EXPECT_EQ(series[1].series_instance_uid, mr_uid);

  // The 20 slices by their uid, their SeriesInstanceUID and index 1: one volume, the shared series' voxels.
  const ImageReadResult shared = readImageFile(folder);
  const ImageReadResult by_uid = readImageFile(dir, ImageReadOptions{series[0].uid});
  const ImageReadResult by_instance_uid = readImageFile(dir, ImageReadOptions{ct_uid});
  const ImageReadResult by_index = readImageFile(dir, ImageReadOptions{"1"});
  expectSameVolume(by_instance_uid, by_uid);
  expectSameVolume(by_index, by_uid);
  expectSameGeometry(by_uid.image, shared.image, 1e-12);
  EXPECT_TRUE(by_uid.image.data == shared.image.data);
  EXPECT_EQ(by_uid.modality, "CT");
  EXPECT_EQ(by_uid.series_instance_uid, ct_uid);

  // The MR series: recognisable, so a CT import can refuse it.
  const ImageReadResult mr = readImageFile(dir, ImageReadOptions{mr_uid});
  EXPECT_EQ(mr.modality, "MR");
  EXPECT_EQ(mr.series_description, "T1 axial");
  EXPECT_EQ(readImageFile(dir, ImageReadOptions{"2"}).modality, "MR");
  EXPECT_EQ(readImageFile(dir / "mr.dcm").modality, "MR");
  // The non-DICOM formats have none.
  writeImage(by_uid.image, dir / "ct.nrrd");
  EXPECT_EQ(readImageFile(dir / "ct.nrrd").modality, "");
}

TEST(ImageIoDicomPeer, Dcm2niixConversionHasTheSameGeometryAndEveryVoxel) {
  // An independent, widely used converter (Chris Rorden's dcm2niix) as the reference for the series'
  // geometry: its NIfTI, read back (RAS header -> LPS), must put every voxel of our DICOM read at the same
  // LPS position with the same value. dcm2niix may reorder rows or slices, so compare in physical space.
  MRSNS_REQUIRE_DATA(folder, "ct/totalsegmentator/example_ct_dicom");
  MRSNS_REQUIRE_TOOL(dcm2niix, "dcm2niix");
  const auto out = test::scratchDirectory("dcm2niix");
  const auto run = test::runProgram(dcm2niix, {"-z", "n", "-b", "n", "-f", "%s", "-o", out.string(), folder.string()});
  ASSERT_EQ(run.exit_code, 0) << run.out << run.err;
  std::vector<std::filesystem::path> niftis;
  for (const auto& entry : std::filesystem::directory_iterator(out)) {
    if (entry.path().extension() == ".nii") niftis.push_back(entry.path());
  }
  ASSERT_EQ(niftis.size(), 1U) << "dcm2niix wrote " << niftis.size() << " NIfTI files: " << run.out;
  const ImageVolume nifti = readImage(niftis.front());
  const ImageVolume dicom = readImage(folder);

  // Geometry: each NIfTI axis is a DICOM axis (up to its sign) with the same size and spacing. NIfTI stores
  // the affine in float32: 1e-6 on unit direction cosines (exact 0/1 here), 1e-4 mm on spacings.
  for (int a = 0; a < 3; ++a) {
    SCOPED_TRACE("NIfTI axis " + std::to_string(a));
    int match = -1;
    for (int b = 0; b < 3; ++b) {
      if (std::abs(nifti.direction.col(a).dot(dicom.direction.col(b))) > 1.0 - 1e-6) match = b;
    }
    ASSERT_GE(match, 0) << "no DICOM axis along " << nifti.direction.col(a).transpose();
    const double sign = nifti.direction.col(a).dot(dicom.direction.col(match)) > 0 ? 1.0 : -1.0;
    EXPECT_LT((nifti.direction.col(a) - sign * dicom.direction.col(match)).cwiseAbs().maxCoeff(), 1e-6);
    EXPECT_EQ(nifti.size[static_cast<std::size_t>(a)], dicom.size[static_cast<std::size_t>(match)]);
    EXPECT_NEAR(nifti.spacing[a], dicom.spacing[match], 1e-4);
  }
  // The NIfTI's first voxel is a corner voxel of the DICOM volume (float32 of ~800 mm: ~6e-5; 1e-3 mm).
  const Eigen::Vector3d corner = dicom.physicalToIndex(nifti.origin);
  const Eigen::Vector3d rounded = corner.array().round().matrix();
  EXPECT_LT((dicom.indexToPhysical(rounded) - nifti.origin).norm(), 1e-3) << corner.transpose();
  for (int a = 0; a < 3; ++a) {
    EXPECT_TRUE(rounded[a] == 0.0 || rounded[a] == dicom.size[static_cast<std::size_t>(a)] - 1) << corner.transpose();
  }
  if (HasFailure()) return;

  // Every voxel: the NIfTI voxel at the same LPS position holds the same value (HU; rescale applied by both).
  std::size_t mismatches = 0, outside = 0;
  double worst_offset = 0.0;
  for (int k = 0; k < dicom.size[2]; ++k) {
    for (int j = 0; j < dicom.size[1]; ++j) {
      for (int i = 0; i < dicom.size[0]; ++i) {
        const Eigen::Vector3d p = dicom.indexToPhysical(Eigen::Vector3d(i, j, k));
        const Eigen::Vector3d q = nifti.physicalToIndex(p);
        const Eigen::Vector3d r = q.array().round().matrix();
        worst_offset = std::max(worst_offset, (q - r).cwiseAbs().maxCoeff());
        const int ni = static_cast<int>(r.x()), nj = static_cast<int>(r.y()), nk = static_cast<int>(r.z());
        if (!nifti.contains(ni, nj, nk)) {
          ++outside;
          continue;
        }
        if (nifti.value(ni, nj, nk) != dicom.value(i, j, k)) ++mismatches;
      }
    }
  }
  EXPECT_EQ(outside, 0U);
  EXPECT_EQ(mismatches, 0U) << "of " << dicom.voxelCount() << " voxels";
  // Within 1e-3 mm of a voxel centre, in voxels (spacing ~1 mm).
  EXPECT_LT(worst_offset, 1e-3);
}

}  // namespace
}  // namespace mrsns::io
