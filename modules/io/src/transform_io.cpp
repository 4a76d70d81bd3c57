// Transform files in and out of Eigen matrices. ITK is reached only through
// itk_bridge.h (see there why).
#include "mrsns/io/transform_io.h"

#include <Eigen/SVD>
#include <algorithm>
#include <array>
#include <cctype>
#include <charconv>
#include <cmath>
#include <fstream>
#include <iomanip>
#include <optional>
#include <sstream>

#include "itk_bridge.h"
#include "io_text.h"
#include "mrsns/core/error.h"
#include "mrsns/io/file_names.h"

namespace mrsns::io {
namespace {

using detail::quoted;

constexpr double kRigidTolerance = 1e-5;


std::string slurp(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw FileError("cannot open transform file " + quoted(path) + ": check that it exists and is readable");
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

bool isItkText(const std::string& text) {
  static const std::string kMagic = "#Insight Transform File";
  const auto start = text.find_first_not_of(" \t\r\n");
  return start != std::string::npos && text.compare(start, kMagic.size(), kMagic) == 0;
}

/// Plain "4 lines of 4 numbers" (commas or whitespace; '#' comments).
Eigen::Matrix4d parseMatrixText(const std::string& text, const std::filesystem::path& path) {
  std::vector<double> values;
  std::istringstream in(text);
  std::string line;
  while (std::getline(in, line)) {
    if (const auto hash = line.find('#'); hash != std::string::npos) line.erase(hash);
    std::replace_if(
        line.begin(), line.end(), [](char c) { return c == ',' || c == ';' || c == '[' || c == ']'; }, ' ');
    std::istringstream tokens(line);
    std::string token;
    while (tokens >> token) {
      double v = 0.0;
      const char* begin = token.data() + (token[0] == '+' ? 1 : 0);
      const auto [ptr, ec] = std::from_chars(begin, token.data() + token.size(), v);
      if (ec != std::errc() || ptr != token.data() + token.size() || !std::isfinite(v)) {
        throw FormatError("transform file " + quoted(path) + ": '" + token +
                          "' is not a finite number (expected a 4x4 matrix: 4 lines of 4 numbers)");
      }
      values.push_back(v);
    }
  }
  if (values.size() != 16) {
    throw FormatError("transform file " + quoted(path) + " holds " + std::to_string(values.size()) +
                      " numbers: expected a 4x4 matrix (4 lines of 4 numbers) or an ITK transform file");
  }
  Eigen::Matrix4d m;
  for (int r = 0; r < 4; ++r) {
    for (int c = 0; c < 4; ++c) m(r, c) = values[static_cast<std::size_t>(r * 4 + c)];
  }
  if ((m.row(3) - Eigen::RowVector4d(0, 0, 0, 1)).cwiseAbs().maxCoeff() > 1e-9) {
    throw FormatError("transform file " + quoted(path) +
                      ": the last row of the 4x4 matrix must be 0 0 0 1 (a projective matrix is not a transform)");
  }
  return m;
}

void classify(TransformFile& file) {
  const Eigen::Matrix3d r = file.matrix.topLeftCorner<3, 3>();
  file.orthonormality_error = (r.transpose() * r - Eigen::Matrix3d::Identity()).norm();
  file.rigid = file.linear && file.orthonormality_error < kRigidTolerance && r.determinant() > 0.0;
}

std::string formatFromExtension(const std::string& ext) {
  if (ext == ".h5" || ext == ".hdf5") return "itk-hdf5";
  if (ext == ".mat") return "itk-matlab";
  return "itk-text";
}

/// ITK's text reader silently leaves a transform at identity when its
/// "Parameters:" line is short and "FixedParameters:" is missing: check the
/// counts ourselves against what ITK built.
void checkItkTextCounts(const std::string& text, const std::vector<detail::RawTransform>& raws,
                        const std::filesystem::path& path) {
  struct Block {
    std::string name;
    std::optional<std::size_t> parameters, fixed;
  };
  std::vector<Block> blocks;
  std::istringstream in(text);
  std::string line;
  auto count = [](const std::string& rest) {
    std::istringstream values(rest);
    std::size_t n = 0;
    std::string token;
    while (values >> token) ++n;
    return n;
  };
  while (std::getline(in, line)) {
    const auto colon = line.find(':');
    if (colon == std::string::npos) continue;
    const std::string key = line.substr(0, colon);
    const std::string rest = line.substr(colon + 1);
    if (key == "Transform") {
      std::istringstream name(rest);
      blocks.push_back({});
      name >> blocks.back().name;
    } else if (key == "Parameters" && !blocks.empty()) {
      blocks.back().parameters = count(rest);
    } else if (key == "FixedParameters" && !blocks.empty()) {
      blocks.back().fixed = count(rest);
    }
  }
  const bool composite = !blocks.empty() && blocks.front().name.rfind("CompositeTransform", 0) == 0;
  if (composite) blocks.erase(blocks.begin());
  std::vector<const detail::RawTransform*> ordered;
  for (const auto& r : raws) ordered.push_back(&r);
  if (composite) std::reverse(ordered.begin(), ordered.end());  // raws come first-applied first
  if (blocks.size() != ordered.size()) {
    throw FormatError("transform file " + quoted(path) + " lists " + std::to_string(blocks.size()) +
                      " transforms but " + std::to_string(ordered.size()) + " could be read");
  }
  for (std::size_t i = 0; i < blocks.size(); ++i) {
    const Block& b = blocks[i];
    const detail::RawTransform& r = *ordered[i];
    if (!b.parameters || *b.parameters != r.parameters.size() || !b.fixed || *b.fixed != r.fixed_parameters.size()) {
      throw FormatError("transform file " + quoted(path) + ": " + b.name + " needs " +
                        std::to_string(r.parameters.size()) + " Parameters and " +
                        std::to_string(r.fixed_parameters.size()) + " FixedParameters, the file gives " +
                        (b.parameters ? std::to_string(*b.parameters) : std::string("no")) + " and " +
                        (b.fixed ? std::to_string(*b.fixed) : std::string("no")));
    }
  }
}

Eigen::Matrix4d linearMatrix(const TransformFile& file, const std::filesystem::path& path) {
  if (!file.linear) {
    std::string names;
    for (const auto& c : file.components) {
      if (!names.empty()) names += ", ";
      names += c;
    }
    throw UnsupportedError("transform file " + quoted(path) + " holds a non-linear transform (" + names +
                           "): a 4x4 matrix cannot represent it");
  }
  return file.matrix;
}

/// `m` as a rigid transform, or UnsupportedError naming the file and how far from rigid it is.
Eigen::Isometry3d rigidFrom(const Eigen::Matrix4d& m, const std::filesystem::path& path, double tolerance,
                            const char* affine_reader) {
  const Eigen::Matrix3d r = m.topLeftCorner<3, 3>();
  const double error = (r.transpose() * r - Eigen::Matrix3d::Identity()).norm();
  if (!(error <= tolerance) || r.determinant() <= 0.0) {
    const Eigen::Vector3d scales = Eigen::JacobiSVD<Eigen::Matrix3d>(r).singularValues();
    std::ostringstream msg;
    msg << "transform file " << quoted(path) << " is not rigid: its 3x3 part has singular values " << scales.x() << ", "
        << scales.y() << ", " << scales.z() << " and determinant " << r.determinant() << " (||R^T R - I|| = " << error
        << " > " << tolerance << "); use " << affine_reader
        << " for scaling or shear, or remove them in the tool that wrote it";
    throw UnsupportedError(msg.str());
  }
  // Project round-off away so the result is exactly a rotation.
  Eigen::JacobiSVD<Eigen::Matrix3d> svd(r, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Isometry3d t = Eigen::Isometry3d::Identity();
  t.linear() = svd.matrixU() * svd.matrixV().transpose();
  t.translation() = m.topRightCorner<3, 1>();
  return t;
}

/// The ratio of the smallest to the largest singular value of the 3x3 part
/// below which an affine is treated as singular: its inverse would carry
/// less than ~4 significant digits.
constexpr double kSingularRatio = 1e-12;

bool invertible(const Eigen::Matrix4d& m, Eigen::Vector3d& singular_values) {
  singular_values = Eigen::JacobiSVD<Eigen::Matrix3d>(Eigen::Matrix3d(m.topLeftCorner<3, 3>())).singularValues();
  return singular_values.z() > kSingularRatio * singular_values.x();
}

/// [A t; 0 1]^-1 = [A^-1, -A^-1 t; 0 1] (the caller checked that A is invertible).
Eigen::Matrix4d affineInverse(const Eigen::Matrix4d& m) {
  const Eigen::Matrix3d a = m.topLeftCorner<3, 3>();
  const Eigen::Matrix3d inverse = a.inverse();
  Eigen::Matrix4d out = Eigen::Matrix4d::Identity();
  out.topLeftCorner<3, 3>() = inverse;
  out.topRightCorner<3, 1>() = -(inverse * m.topRightCorner<3, 1>());
  return out;
}

std::string singularText(const Eigen::Vector3d& s) {
  std::ostringstream out;
  out << s.x() << ", " << s.y() << ", " << s.z();
  return out.str();
}

bool isItkExtension(const std::string& ext) {
  return ext == ".tfm" || ext == ".h5" || ext == ".hdf5" || ext == ".mat";
}

}  // namespace

TransformFile readTransformFile(const std::filesystem::path& path) {
  const std::string ext = lowerExtension(path);
  if (ext != ".tfm" && ext != ".txt" && ext != ".h5" && ext != ".hdf5" && ext != ".mat") {
    throw UnsupportedError("transform file " + quoted(path) + " has an unknown extension '" + ext +
                           "': use .tfm, .h5, .mat or .txt");
  }
  TransformFile file;
  std::string itk_text;
  if (ext == ".tfm" || ext == ".txt") {
    const std::string text = slurp(path);
    if (!isItkText(text)) {
      if (ext == ".tfm") {
        throw FormatError("transform file " + quoted(path) +
                          " does not start with '#Insight Transform File': it is not an ITK/Slicer transform");
      }
      file.format = "matrix-text";
      file.linear = true;
      file.matrix = parseMatrixText(text, path);
      classify(file);
      return file;
    }
    itk_text = text;
  } else {
    std::ifstream probe(path, std::ios::binary);
    if (!probe)
      throw FileError("cannot open transform file " + quoted(path) + ": check that it exists and is readable");
  }
  file.format = formatFromExtension(ext);
  const std::vector<detail::RawTransform> raws = detail::readRawTransforms(path);
  if (!itk_text.empty()) checkItkTextCounts(itk_text, raws, path);
  file.linear = true;
  Eigen::Matrix4d total = Eigen::Matrix4d::Identity();
  for (const auto& raw : raws) {
    file.components.push_back(raw.class_name);
    if (!raw.linear) {
      file.linear = false;
      continue;
    }
    Eigen::Matrix4d m = Eigen::Matrix4d::Identity();
    for (int r = 0; r < 3; ++r) {
      for (int c = 0; c < 3; ++c) m(r, c) = raw.matrix[static_cast<std::size_t>(r * 3 + c)];
      m(r, 3) = raw.offset[static_cast<std::size_t>(r)];
    }
    if (!m.allFinite()) throw FormatError("transform file " + quoted(path) + " holds non-finite parameters");
    // Components come first-applied first (a composite is flattened so);
    // several top-level transforms are composed in file order too.
    total = m * total;
  }
  file.matrix = file.linear ? total : Eigen::Matrix4d::Identity();
  classify(file);
  return file;
}

Eigen::Matrix4d readLinearTransform(const std::filesystem::path& path) {
  return linearMatrix(readTransformFile(path), path);
}

Eigen::Isometry3d readRigidTransform(const std::filesystem::path& path, double tolerance) {
  return rigidFrom(readLinearTransform(path), path, tolerance, "readLinearTransform");
}

void writeTransformFile(const Eigen::Matrix4d& transform, const std::filesystem::path& path) {
  if (!transform.allFinite()) {
    throw InvalidArgumentError("cannot write transform to " + quoted(path) + ": the matrix has non-finite entries");
  }
  if ((transform.row(3) - Eigen::RowVector4d(0, 0, 0, 1)).cwiseAbs().maxCoeff() > 1e-12) {
    throw InvalidArgumentError("cannot write transform to " + quoted(path) + ": the last row must be 0 0 0 1");
  }
  const std::string ext = lowerExtension(path);
  if (ext == ".txt") {
    std::ofstream out(path, std::ios::trunc);
    if (!out) throw FileError("cannot write transform file " + quoted(path) + ": check the folder exists");
    out << std::setprecision(17);
    for (int r = 0; r < 4; ++r) {
      out << transform(r, 0) << ' ' << transform(r, 1) << ' ' << transform(r, 2) << ' ' << transform(r, 3) << '\n';
    }
    out.flush();
    if (!out) throw FileError("writing transform file " + quoted(path) + " failed (disk full?)");
    return;
  }
  if (ext != ".tfm" && ext != ".h5" && ext != ".hdf5" && ext != ".mat") {
    throw UnsupportedError("cannot write transform to " + quoted(path) + ": use .tfm, .h5, .mat or .txt");
  }
  std::array<double, 9> matrix{};
  std::array<double, 3> offset{};
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) matrix[static_cast<std::size_t>(r * 3 + c)] = transform(r, c);
    offset[static_cast<std::size_t>(r)] = transform(r, 3);
  }
  detail::writeRawAffine(matrix, offset, path);
}

void writeChildToParent(const Eigen::Matrix4d& parent_T_child, const std::filesystem::path& path) {
  if (!parent_T_child.allFinite()) {
    throw InvalidArgumentError("cannot write transform to " + quoted(path) + ": the matrix has non-finite entries");
  }
  if ((parent_T_child.row(3) - Eigen::RowVector4d(0, 0, 0, 1)).cwiseAbs().maxCoeff() > 1e-12) {
    throw InvalidArgumentError("cannot write transform to " + quoted(path) +
                               ": the last row must be 0 0 0 1 (a projective matrix is not a transform)");
  }
  const std::string ext = lowerExtension(path);
  if (ext == ".txt") {
    writeTransformFile(parent_T_child, path);  // a plain matrix: parent_T_child as it is
    return;
  }
  if (!isItkExtension(ext)) {
    throw UnsupportedError("cannot write transform to " + quoted(path) + ": use .tfm, .h5, .mat or .txt");
  }
  Eigen::Vector3d s;
  if (!invertible(parent_T_child, s)) {
    throw InvalidArgumentError("cannot write transform to " + quoted(path) +
                               ": its 3x3 part is singular (singular values " + singularText(s) +
                               "), and an ITK file holds the inverse; write it as a plain .txt matrix, or check "
                               "the calibration that produced it");
  }
  writeTransformFile(affineInverse(parent_T_child), path);
}

Eigen::Matrix4d readChildToParent(const std::filesystem::path& path) {
  const TransformFile file = readTransformFile(path);
  const Eigen::Matrix4d m = linearMatrix(file, path);
  if (file.format == "matrix-text") return m;
  Eigen::Vector3d s;
  if (!invertible(m, s)) {
    throw FormatError("transform file " + quoted(path) + " holds a singular transform (singular values " +
                      singularText(s) + "): it has no inverse, so it cannot be a node's ChildToParent");
  }
  return affineInverse(m);
}

Eigen::Isometry3d readChildToParentRigid(const std::filesystem::path& path, double tolerance) {
  return rigidFrom(readChildToParent(path), path, tolerance, "readChildToParent");
}

Eigen::Matrix4d parentFromChildLps(const Eigen::Matrix4d& file_transform) {
  return file_transform.inverse();
}

Eigen::Matrix4d flipRasLps(const Eigen::Matrix4d& transform) {
  const Eigen::Matrix4d flip = Eigen::Vector4d(-1.0, -1.0, 1.0, 1.0).asDiagonal();
  return flip * transform * flip;
}

Eigen::Matrix4d slicerToParentRas(const Eigen::Matrix4d& file_transform) {
  return flipRasLps(file_transform.inverse());
}

Eigen::Matrix4d fileTransformFromSlicerToParentRas(const Eigen::Matrix4d& to_parent_ras) {
  return flipRasLps(to_parent_ras).inverse();
}

}  // namespace mrsns::io
