#include "header_checks.h"

#include <unistd.h>
#include <zlib.h>

#include <Eigen/Geometry>
#include <Eigen/SVD>
#include <algorithm>
#include <array>
#include <atomic>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <map>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

#include "io_text.h"
#include "mrsns/core/error.h"

namespace mrsns::io::detail {
namespace {

constexpr int kHeaderSize = 348;


/// The decompressed bytes of a (possibly gzipped) file; `complete` is false
/// when the compressed stream ends early or is corrupt.
std::vector<unsigned char> readAll(const std::filesystem::path& path, bool& complete) {
  std::vector<unsigned char> bytes;
  complete = false;
  gzFile gz = gzopen(path.string().c_str(), "rb");
  if (gz == nullptr) return bytes;
  std::vector<unsigned char> chunk(1 << 20);
  for (;;) {
    const int n = gzread(gz, chunk.data(), static_cast<unsigned>(chunk.size()));
    if (n < 0) break;
    if (n == 0) {
      int err = Z_OK;
      gzerror(gz, &err);
      complete = (err == Z_OK || err == Z_STREAM_END);
      break;
    }
    bytes.insert(bytes.end(), chunk.begin(), chunk.begin() + n);
  }
  gzclose(gz);
  return bytes;
}

/// The first `count` decompressed bytes of a (possibly gzipped) file (fewer when it is shorter).
std::vector<unsigned char> readStart(const std::filesystem::path& path, std::size_t count) {
  std::vector<unsigned char> bytes(count);
  gzFile gz = gzopen(path.string().c_str(), "rb");
  if (gz == nullptr) return {};
  const int n = gzread(gz, bytes.data(), static_cast<unsigned>(count));
  gzclose(gz);
  bytes.resize(n > 0 ? static_cast<std::size_t>(n) : 0);
  return bytes;
}

/// The decompressed length of a (possibly gzipped) file, counted without keeping it; `complete` is false when
/// the compressed stream ends early or is corrupt.
std::uint64_t decompressedLength(const std::filesystem::path& path, bool& complete) {
  complete = false;
  gzFile gz = gzopen(path.string().c_str(), "rb");
  if (gz == nullptr) return 0;
  std::vector<unsigned char> chunk(1 << 20);
  std::uint64_t length = 0;
  for (;;) {
    const int n = gzread(gz, chunk.data(), static_cast<unsigned>(chunk.size()));
    if (n < 0) break;
    if (n == 0) {
      int err = Z_OK;
      gzerror(gz, &err);
      complete = (err == Z_OK || err == Z_STREAM_END);
      break;
    }
    length += static_cast<std::uint64_t>(n);
  }
  gzclose(gz);
  return length;
}

/// A gzip file's own record of its uncompressed length (ISIZE: the last member's length modulo 2^32); none for
/// a file that is not gzip.
std::optional<std::uint32_t> gzipRecordedLength(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  unsigned char magic[2] = {0, 0};
  if (!in.read(reinterpret_cast<char*>(magic), 2) || magic[0] != 0x1f || magic[1] != 0x8b) return std::nullopt;
  in.seekg(-4, std::ios::end);
  unsigned char trailer[4] = {0, 0, 0, 0};
  if (!in.read(reinterpret_cast<char*>(trailer), 4)) return std::nullopt;
  return static_cast<std::uint32_t>(trailer[0]) | (static_cast<std::uint32_t>(trailer[1]) << 8) |
         (static_cast<std::uint32_t>(trailer[2]) << 16) | (static_cast<std::uint32_t>(trailer[3]) << 24);
}

template <typename T>
T field(const std::vector<unsigned char>& h, std::size_t at) {
  T v;
  std::memcpy(&v, h.data() + at, sizeof v);
  return v;
}

template <typename T>
void setField(std::vector<unsigned char>& h, std::size_t at, T v) {
  std::memcpy(h.data() + at, &v, sizeof v);
}

bool isLittleEndianNifti1(const std::vector<unsigned char>& h) {
  return h.size() >= static_cast<std::size_t>(kHeaderSize) && field<std::int32_t>(h, 0) == kHeaderSize &&
         (std::memcmp(h.data() + 344, "n+1", 4) == 0 || std::memcmp(h.data() + 344, "ni1", 4) == 0);
}

}  // namespace

void checkNiftiLength(const std::filesystem::path& path) {
  const std::vector<unsigned char> bytes = readStart(path, kHeaderSize);
  if (!isLittleEndianNifti1(bytes) || std::memcmp(bytes.data() + 344, "n+1", 4) != 0) return;
  const int dims = field<std::int16_t>(bytes, 40);
  if (dims < 1 || dims > 7)
    throw FormatError("NIfTI file " + quoted(path) + " declares " + std::to_string(dims) + " dimensions");
  std::uint64_t voxels = 1;
  for (int i = 1; i <= dims; ++i) {
    const auto extent = field<std::int16_t>(bytes, static_cast<std::size_t>(40 + 2 * i));
    if (extent < 1)
      throw FormatError("NIfTI file " + quoted(path) + " declares a size below 1 along axis " + std::to_string(i));
    voxels *= static_cast<std::uint64_t>(extent);
  }
  const auto bitpix = static_cast<std::uint64_t>(std::max<std::int16_t>(field<std::int16_t>(bytes, 72), 0));
  const auto offset = static_cast<std::uint64_t>(std::max(field<float>(bytes, 108), 0.0F));
  const std::uint64_t expected = offset + voxels * bitpix / 8;
  // Most files answer from their size (plain) or their gzip trailer (a truncated stream ends in compressed data,
  // which matches the expected length by chance once in 2^32); only the rest are decompressed to be counted,
  // instead of decompressing every CT twice (here and in the reader).
  bool complete = true;
  std::uint64_t length = 0;
  if (const auto recorded = gzipRecordedLength(path)) {
    if (*recorded == static_cast<std::uint32_t>(expected & 0xffffffffULL)) return;
    length = decompressedLength(path, complete);
  } else {
    std::error_code ec;
    length = std::filesystem::file_size(path, ec);
    if (ec) return;  // the reader says why it cannot read it
  }
  if (!complete || length < expected) {
    throw FormatError("NIfTI file " + quoted(path) + " is truncated: its header declares " + std::to_string(expected) +
                      " bytes but " + (complete ? "" : "the compressed stream breaks off after ") +
                      std::to_string(length) + (complete ? " are present" : " bytes") + "; copy or export it again");
  }
}

void checkMetaImageLength(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return;
  std::map<std::string, std::string> fields;
  std::string line;
  std::uint64_t header_end = 0;
  while (std::getline(in, line)) {
    header_end = static_cast<std::uint64_t>(in.tellg());
    const auto eq = line.find('=');
    if (eq == std::string::npos) return;  // not a MetaImage header: let ITK judge
    auto trim = [](std::string s) {
      const auto b = s.find_first_not_of(" \t\r");
      const auto e = s.find_last_not_of(" \t\r");
      return b == std::string::npos ? std::string() : s.substr(b, e - b + 1);
    };
    const std::string key = trim(line.substr(0, eq));
    fields[key] = trim(line.substr(eq + 1));
    if (key == "ElementDataFile") break;
    if (fields.size() > 200) return;
  }
  if (!fields.count("ElementDataFile") || !fields.count("DimSize") || !fields.count("ElementType")) return;
  static const std::map<std::string, std::uint64_t> kSizes = {
      {"MET_UCHAR", 1},      {"MET_CHAR", 1},      {"MET_USHORT", 2}, {"MET_SHORT", 2},
      {"MET_UINT", 4},       {"MET_INT", 4},       {"MET_ULONG", 8},  {"MET_LONG", 8},
      {"MET_ULONG_LONG", 8}, {"MET_LONG_LONG", 8}, {"MET_FLOAT", 4},  {"MET_DOUBLE", 8}};
  const auto element = kSizes.find(fields["ElementType"]);
  if (element == kSizes.end()) return;
  std::uint64_t expected = element->second;
  std::istringstream dims(fields["DimSize"]);
  std::int64_t extent = 0;
  while (dims >> extent) {
    if (extent < 1) throw FormatError("MetaImage " + quoted(path) + " declares a size below 1 (DimSize)");
    expected *= static_cast<std::uint64_t>(extent);
  }
  if (fields.count("ElementNumberOfChannels")) {
    expected *= static_cast<std::uint64_t>(std::max(1L, std::atol(fields["ElementNumberOfChannels"].c_str())));
  }
  const std::string data_file = fields["ElementDataFile"];
  std::error_code ec;
  std::uint64_t available = 0;
  if (data_file == "LOCAL") {
    available = std::filesystem::file_size(path, ec) - header_end;
  } else if (data_file.find('%') == std::string::npos && data_file.rfind("LIST", 0) != 0) {
    const auto external = path.parent_path() / data_file;
    available = std::filesystem::file_size(external, ec);
    if (ec) throw FormatError("MetaImage " + quoted(path) + ": its data file " + quoted(external) + " is missing");
    const long header_size = fields.count("HeaderSize") ? std::atol(fields["HeaderSize"].c_str()) : 0;
    if (header_size < 0) return;  // data at the end of the file: nothing to check
    available =
        available > static_cast<std::uint64_t>(header_size) ? available - static_cast<std::uint64_t>(header_size) : 0;
  } else {
    return;
  }
  if (ec) return;
  const bool compressed =
      fields.count("CompressedData") && (fields["CompressedData"] == "True" || fields["CompressedData"] == "true");
  if (compressed) {
    if (!fields.count("CompressedDataSize")) return;
    expected = static_cast<std::uint64_t>(std::max(0LL, std::atoll(fields["CompressedDataSize"].c_str())));
  }
  if (available < expected) {
    throw FormatError("MetaImage " + quoted(path) + " is truncated: its header declares " + std::to_string(expected) +
                      (compressed ? " compressed" : "") + " bytes of voxels but only " + std::to_string(available) +
                      " are present; copy or export it again");
  }
}

std::optional<RepairedNifti> niftiWithQformFromSform(const std::filesystem::path& path, double tolerance) {
  bool complete = false;
  std::vector<unsigned char> bytes = readAll(path, complete);
  if (!complete || !isLittleEndianNifti1(bytes) || std::memcmp(bytes.data() + 344, "n+1", 4) != 0) return std::nullopt;
  if (field<std::int16_t>(bytes, 254) <= 0) return std::nullopt;  // no sform to take the geometry from
  Eigen::Matrix3d a;
  Eigen::Vector3d offset;
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) a(r, c) = field<float>(bytes, static_cast<std::size_t>(280 + 16 * r + 4 * c));
    offset[r] = field<float>(bytes, static_cast<std::size_t>(280 + 16 * r + 12));
  }
  const Eigen::Vector3d spacing = a.colwise().norm();
  if (!a.allFinite() || (spacing.array() <= 0.0).any()) return std::nullopt;
  Eigen::Matrix3d r = a * spacing.cwiseInverse().asDiagonal();
  RepairedNifti result;
  result.deviation = (r.transpose() * r - Eigen::Matrix3d::Identity()).norm();
  if (result.deviation > tolerance) return std::nullopt;
  float qfac = 1.0F;
  if (r.determinant() < 0.0) {
    r.col(2) *= -1.0;  // NIfTI's qfac carries the reflection
    qfac = -1.0F;
  }
  Eigen::JacobiSVD<Eigen::Matrix3d> svd(r, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Quaterniond q(Eigen::Matrix3d(svd.matrixU() * svd.matrixV().transpose()));
  if (q.w() < 0.0) q.coeffs() *= -1.0;  // NIfTI derives a = +sqrt(1 - b^2 - c^2 - d^2)
  setField<std::int16_t>(bytes, 252, field<std::int16_t>(bytes, 254));
  setField<std::int16_t>(bytes, 254, 0);
  setField<float>(bytes, 256, static_cast<float>(q.x()));
  setField<float>(bytes, 260, static_cast<float>(q.y()));
  setField<float>(bytes, 264, static_cast<float>(q.z()));
  for (int i = 0; i < 3; ++i) {
    setField<float>(bytes, static_cast<std::size_t>(268 + 4 * i), static_cast<float>(offset[i]));
    setField<float>(bytes, static_cast<std::size_t>(80 + 4 * i), static_cast<float>(spacing[i]));
  }
  setField<float>(bytes, 76, qfac);
  static std::atomic<int> counter{0};
  result.path = std::filesystem::temp_directory_path() /
                ("mrsns-nifti-" + std::to_string(::getpid()) + "-" + std::to_string(counter++) + ".nii");
  std::ofstream out(result.path, std::ios::binary | std::ios::trunc);
  out.write(reinterpret_cast<const char*>(bytes.data()), static_cast<std::streamsize>(bytes.size()));
  if (!out) return std::nullopt;
  return result;
}

}  // namespace mrsns::io::detail
