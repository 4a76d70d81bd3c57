#include "mrsns/io/pose_csv.h"

#include <array>
#include <charconv>
#include <cmath>
#include <fstream>
#include <iomanip>
#include <sstream>
#include <string>

#include "mrsns/core/error.h"
#include "mrsns/core/rigid.h"

namespace mrsns::io {
namespace {

bool parseNumbers(const std::string& line, std::vector<double>& values) {
  values.clear();
  std::size_t i = 0;
  while (i < line.size()) {
    while (i < line.size() && (line[i] == ',' || line[i] == ';' || std::isspace(static_cast<unsigned char>(line[i])))) {
      ++i;
    }
    if (i >= line.size()) break;
    std::size_t end = i;
    while (end < line.size() && line[end] != ',' && line[end] != ';' &&
           !std::isspace(static_cast<unsigned char>(line[end]))) {
      ++end;
    }
    double v = 0.0;
    const auto [ptr, ec] = std::from_chars(line.data() + i, line.data() + end, v);
    if (ec != std::errc() || ptr != line.data() + end) return false;
    values.push_back(v);
    i = end;
  }
  return true;
}

}  // namespace

PoseCsv readPoseCsv(const std::filesystem::path& path) {
  std::ifstream in(path);
  if (!in) throw FileError("cannot open pose file '" + path.string() + "': check the path and permissions");
  PoseCsv csv;
  std::string line;
  std::vector<double> values;
  int line_number = 0;
  bool first_content_line = true;
  while (std::getline(in, line)) {
    ++line_number;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    if (line.find_first_not_of(" \t") == std::string::npos || line[line.find_first_not_of(" \t")] == '#') continue;
    const bool numeric = parseNumbers(line, values);
    if (!numeric && first_content_line) {
      first_content_line = false;  // a header of column names
      continue;
    }
    first_content_line = false;
    if (!numeric || (values.size() != 16 && values.size() != 17)) {
      throw FormatError("pose file '" + path.string() + "', line " + std::to_string(line_number) +
                        ": expected 16 numbers (4x4 row major) or 17 (timestamp + 16), found " +
                        (numeric ? std::to_string(values.size()) + " numbers" : std::string("non-numeric text")));
    }
    const bool timed = values.size() == 17;
    if (!csv.poses.empty() && timed != !csv.timestamps.empty()) {
      throw FormatError("pose file '" + path.string() + "', line " + std::to_string(line_number) +
                        ": mixes lines with and without a timestamp column");
    }
    std::array<double, 16> m{};
    std::copy(values.end() - 16, values.end(), m.begin());
    Eigen::Matrix4d matrix;
    try {
      matrix = matrixFromRowMajor(m);
    } catch (const Error&) {
      throw FormatError("pose file '" + path.string() + "', line " + std::to_string(line_number) +
                        ": the matrix has a non-finite value");
    }
    if (!isRigid(matrix, 1e-3)) {
      throw FormatError("pose file '" + path.string() + "', line " + std::to_string(line_number) +
                        ": the matrix is not a rigid transform (rotation not orthonormal or last row not 0 0 0 1)");
    }
    csv.poses.push_back(orthonormalize(matrix));
    if (timed) csv.timestamps.push_back(values.front());
  }
  if (in.bad()) throw FileError("error while reading pose file '" + path.string() + "'");
  if (csv.poses.empty()) throw FormatError("pose file '" + path.string() + "' contains no poses");
  return csv;
}

void writePoseCsv(const std::filesystem::path& path, const std::vector<Eigen::Isometry3d>& poses,
                  const std::vector<double>& timestamps) {
  if (!timestamps.empty() && timestamps.size() != poses.size()) {
    throw InvalidArgumentError("writePoseCsv: " + std::to_string(timestamps.size()) + " timestamps for " +
                               std::to_string(poses.size()) + " poses");
  }
  std::ofstream out(path);
  if (!out) throw FileError("cannot write pose file '" + path.string() + "': check the folder and permissions");
  out << std::setprecision(17);
  out << "# pose per line: " << (timestamps.empty() ? "" : "timestamp_s, ") << "4x4 matrix row major (mm)\n";
  for (std::size_t i = 0; i < poses.size(); ++i) {
    if (!timestamps.empty()) out << timestamps[i] << ',';
    const auto values = toRowMajor(poses[i]);
    for (std::size_t k = 0; k < 16; ++k) out << values[k] << (k == 15 ? '\n' : ',');
  }
  if (!out) throw FileError("error while writing pose file '" + path.string() + "' (disk full?)");
}

}  // namespace mrsns::io
