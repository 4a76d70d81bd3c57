#include "mrsns/io/statismo_io.h"

#include <hdf5.h>

#include <chrono>
#include <cmath>
#include <ctime>
#include <vector>

#include "mrsns/core/dense_solvers.h"
#include "mrsns/core/error.h"

namespace mrsns::io {
namespace {

// Closes an HDF5 handle with the matching H5?close when it goes out of scope.
class Handle {
 public:
  Handle(hid_t id, herr_t (*closer)(hid_t)) : id_(id), closer_(closer) {}
  ~Handle() {
    if (id_ >= 0) closer_(id_);
  }
  Handle(const Handle&) = delete;
  Handle& operator=(const Handle&) = delete;
  Handle(Handle&& other) noexcept : id_(other.id_), closer_(other.closer_) { other.id_ = -1; }
  Handle& operator=(Handle&&) = delete;
  [[nodiscard]] hid_t get() const { return id_; }
  [[nodiscard]] bool valid() const { return id_ >= 0; }

 private:
  hid_t id_;
  herr_t (*closer_)(hid_t);
};

// HDF5 prints its error stack to stderr by default; errors here become exceptions.
void silenceHdf5() {
  H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr);
}

std::string where(const std::filesystem::path& path, const std::string& object) {
  return path.string() + " (" + object + ")";
}

bool exists(hid_t file, const char* path) {
  // H5Lexists needs every intermediate group to exist: walk the components.
  std::string p(path);
  std::size_t pos = 1;
  while (true) {
    const std::size_t next = p.find('/', pos);
    const std::string prefix = p.substr(0, next);
    if (H5Lexists(file, prefix.c_str(), H5P_DEFAULT) <= 0) return false;
    if (next == std::string::npos) return true;
    pos = next + 1;
  }
}

// Reads a dataset of any numeric type as doubles; dims receives its shape.
std::vector<double> readDoubles(hid_t file, const char* name, const std::filesystem::path& path,
                                std::vector<hsize_t>& dims) {
  if (!exists(file, name)) {
    throw FormatError(where(path, name) + ": dataset missing; not a statismo shape model");
  }
  Handle ds(H5Dopen2(file, name, H5P_DEFAULT), H5Dclose);
  if (!ds.valid()) throw FormatError(where(path, name) + ": cannot open dataset");
  Handle type(H5Dget_type(ds.get()), H5Tclose);
  const H5T_class_t cls = H5Tget_class(type.get());
  if (cls != H5T_FLOAT && cls != H5T_INTEGER) {
    throw FormatError(where(path, name) + ": expected a numeric dataset");
  }
  Handle space(H5Dget_space(ds.get()), H5Sclose);
  const int rank = H5Sget_simple_extent_ndims(space.get());
  if (rank < 0 || rank > 2) throw FormatError(where(path, name) + ": expected a scalar, vector or matrix");
  dims.assign(static_cast<std::size_t>(rank), 0);
  if (rank > 0) H5Sget_simple_extent_dims(space.get(), dims.data(), nullptr);
  hsize_t count = 1;
  for (hsize_t d : dims) count *= d;
  std::vector<double> values(static_cast<std::size_t>(count));
  if (count > 0 && H5Dread(ds.get(), H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT, values.data()) < 0) {
    throw FormatError(where(path, name) + ": cannot read data");
  }
  return values;
}

std::vector<int> readInts(hid_t file, const char* name, const std::filesystem::path& path, std::vector<hsize_t>& dims) {
  std::vector<double> v = readDoubles(file, name, path, dims);
  std::vector<int> out(v.size());
  for (std::size_t i = 0; i < v.size(); ++i) {
    if (v[i] != std::floor(v[i]) || v[i] < 0 || v[i] > 2147483647.0) {
      throw FormatError(where(path, name) + ": cell index " + std::to_string(v[i]) + " is not a valid index");
    }
    out[i] = static_cast<int>(v[i]);
  }
  return out;
}

std::string readStringAttribute(hid_t object, const char* name, const std::filesystem::path& path) {
  if (H5Aexists(object, name) <= 0) return {};
  Handle attr(H5Aopen(object, name, H5P_DEFAULT), H5Aclose);
  Handle type(H5Aget_type(attr.get()), H5Tclose);
  if (H5Tget_class(type.get()) != H5T_STRING) {
    throw FormatError(where(path, std::string("attribute ") + name) + ": expected a string");
  }
  if (H5Tis_variable_str(type.get()) > 0) {
    char* s = nullptr;
    Handle mem(H5Tcopy(H5T_C_S1), H5Tclose);
    H5Tset_size(mem.get(), H5T_VARIABLE);
    if (H5Aread(attr.get(), mem.get(), &s) < 0 || s == nullptr) return {};
    std::string out(s);
    H5free_memory(s);
    return out;
  }
  const std::size_t size = H5Tget_size(type.get());
  Handle space(H5Aget_space(attr.get()), H5Sclose);
  const hssize_t n = std::max<hssize_t>(1, H5Sget_simple_extent_npoints(space.get()));
  std::vector<char> buf(size * static_cast<std::size_t>(n) + 1, '\0');
  if (H5Aread(attr.get(), type.get(), buf.data()) < 0) return {};
  return std::string(buf.data(), strnlen(buf.data(), size));
}

std::string readStringDataset(hid_t file, const char* name) {
  if (!exists(file, name)) return {};
  Handle ds(H5Dopen2(file, name, H5P_DEFAULT), H5Dclose);
  Handle type(H5Dget_type(ds.get()), H5Tclose);
  if (H5Tget_class(type.get()) != H5T_STRING || H5Tis_variable_str(type.get()) > 0) return {};
  const std::size_t size = H5Tget_size(type.get());
  std::vector<char> buf(size + 1, '\0');
  Handle space(H5Dget_space(ds.get()), H5Sclose);
  if (H5Sget_simple_extent_npoints(space.get()) != 1) return {};
  if (H5Dread(ds.get(), type.get(), H5S_ALL, H5S_ALL, H5P_DEFAULT, buf.data()) < 0) return {};
  return std::string(buf.data(), strnlen(buf.data(), size));
}

int readVersion(hid_t file, const char* name, const std::filesystem::path& path) {
  std::vector<hsize_t> dims;
  const std::vector<double> v = readDoubles(file, name, path, dims);
  if (v.size() != 1) throw FormatError(where(path, name) + ": expected one integer");
  return static_cast<int>(v[0]);
}

// --- writing ---------------------------------------------------------------

void writeMatrix(hid_t loc, const char* name, const double* data, std::vector<hsize_t> dims, bool dbl,
                 const std::filesystem::path& path) {
  Handle space(
      dims.empty() ? H5Screate(H5S_SCALAR) : H5Screate_simple(static_cast<int>(dims.size()), dims.data(), nullptr),
      H5Sclose);
  const hid_t file_type = dbl ? H5T_IEEE_F64LE : H5T_IEEE_F32LE;
  Handle ds(H5Dcreate2(loc, name, file_type, space.get(), H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT), H5Dclose);
  if (!ds.valid() || H5Dwrite(ds.get(), H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT, data) < 0) {
    throw FileError(where(path, name) + ": cannot write dataset");
  }
}

void writeInts(hid_t loc, const char* name, const int* data, std::vector<hsize_t> dims,
               const std::filesystem::path& path) {
  Handle space(
      dims.empty() ? H5Screate(H5S_SCALAR) : H5Screate_simple(static_cast<int>(dims.size()), dims.data(), nullptr),
      H5Sclose);
  Handle ds(H5Dcreate2(loc, name, H5T_STD_I32LE, space.get(), H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT), H5Dclose);
  if (!ds.valid() || H5Dwrite(ds.get(), H5T_NATIVE_INT, H5S_ALL, H5S_ALL, H5P_DEFAULT, data) < 0) {
    throw FileError(where(path, name) + ": cannot write dataset");
  }
}

// statismo writes strings as fixed-length, null-terminated, one-element arrays.
Handle stringType(const std::string& s) {
  Handle type(H5Tcopy(H5T_C_S1), H5Tclose);
  H5Tset_size(type.get(), s.size() + 1);
  H5Tset_strpad(type.get(), H5T_STR_NULLTERM);
  return type;
}

void writeStringAttribute(hid_t loc, const char* name, const std::string& value, const std::filesystem::path& path) {
  Handle type = stringType(value);
  const hsize_t one = 1;
  Handle space(H5Screate_simple(1, &one, nullptr), H5Sclose);
  Handle attr(H5Acreate2(loc, name, type.get(), space.get(), H5P_DEFAULT, H5P_DEFAULT), H5Aclose);
  if (!attr.valid() || H5Awrite(attr.get(), type.get(), value.c_str()) < 0) {
    throw FileError(where(path, std::string("attribute ") + name) + ": cannot write");
  }
}

void writeStringDataset(hid_t loc, const char* name, const std::string& value, const std::filesystem::path& path) {
  Handle type = stringType(value);
  const hsize_t one = 1;
  Handle space(H5Screate_simple(1, &one, nullptr), H5Sclose);
  Handle ds(H5Dcreate2(loc, name, type.get(), space.get(), H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT), H5Dclose);
  if (!ds.valid() || H5Dwrite(ds.get(), type.get(), H5S_ALL, H5S_ALL, H5P_DEFAULT, value.c_str()) < 0) {
    throw FileError(where(path, name) + ": cannot write");
  }
}

Handle makeGroup(hid_t loc, const char* name, const std::filesystem::path& path) {
  Handle g(H5Gcreate2(loc, name, H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT), H5Gclose);
  if (!g.valid()) throw FileError(where(path, name) + ": cannot create group");
  return g;
}

std::string nowText() {
  const std::time_t t = std::chrono::system_clock::to_time_t(std::chrono::system_clock::now());
  char buf[64];
  std::tm tm{};
  gmtime_r(&t, &tm);
  std::strftime(buf, sizeof buf, "%a %b %d %H:%M:%S UTC %Y", &tm);
  return buf;
}

}  // namespace

ShapeModel readStatismoModel(const std::filesystem::path& path, StatismoFileInfo* info) {
  silenceHdf5();
  if (!std::filesystem::is_regular_file(path)) {
    throw FileError(path.string() + ": no such file; give the path of a statismo .h5 model");
  }
  if (H5Fis_hdf5(path.c_str()) <= 0) {
    throw FormatError(path.string() + ": not an HDF5 file; a statismo model is an HDF5 (.h5) file");
  }
  Handle file(H5Fopen(path.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT), H5Fclose);
  if (!file.valid()) throw FormatError(path.string() + ": HDF5 file cannot be opened (corrupt?)");
  const hid_t f = file.get();
  if (!exists(f, "/model") || !exists(f, "/representer")) {
    throw FormatError(path.string() + ": HDF5 file without /model and /representer; not a statismo model");
  }
  StatismoFileInfo hdr;
  hdr.major_version = exists(f, "/version/majorVersion") ? readVersion(f, "/version/majorVersion", path) : 0;
  hdr.minor_version = exists(f, "/version/minorVersion") ? readVersion(f, "/version/minorVersion", path) : 8;
  if (hdr.major_version != 0 || hdr.minor_version < 8) {
    throw UnsupportedError(path.string() + ": statismo format " + std::to_string(hdr.major_version) + "." +
                           std::to_string(hdr.minor_version) + " is not supported (0.8 and 0.9 are)");
  }
  {
    Handle rep(H5Gopen2(f, "/representer", H5P_DEFAULT), H5Gclose);
    hdr.representer_name = readStringAttribute(rep.get(), "name", path);
    hdr.dataset_type = readStringAttribute(rep.get(), "datasetType", path);
  }
  hdr.build_time = readStringDataset(f, "/modelinfo/build-time");
  if (!hdr.dataset_type.empty() && hdr.dataset_type != "POLYGON_MESH") {
    throw UnsupportedError(path.string() + ": representer '" + hdr.representer_name + "' holds " + hdr.dataset_type +
                           " data; only shape models of polygon meshes are supported");
  }
  if (!exists(f, "/representer/points") || !exists(f, "/representer/cells")) {
    throw UnsupportedError(path.string() + ": representer '" + hdr.representer_name +
                           "' does not store /representer/points and /representer/cells (only the standard mesh "
                           "representer layout is supported)");
  }

  std::vector<hsize_t> d_mean, d_basis, d_var, d_noise, d_pts, d_cells;
  const std::vector<double> mean = readDoubles(f, "/model/mean", path, d_mean);
  const std::vector<double> basis = readDoubles(f, "/model/pcaBasis", path, d_basis);
  const std::vector<double> var = readDoubles(f, "/model/pcaVariance", path, d_var);
  const std::vector<double> noise = readDoubles(f, "/model/noiseVariance", path, d_noise);
  const std::vector<double> pts = readDoubles(f, "/representer/points", path, d_pts);
  const std::vector<int> cells = readInts(f, "/representer/cells", path, d_cells);

  const auto dim = static_cast<Eigen::Index>(mean.size());
  const auto modes = static_cast<Eigen::Index>(var.size());
  if (d_basis.size() != 2 || static_cast<Eigen::Index>(d_basis[0]) != dim ||
      static_cast<Eigen::Index>(d_basis[1]) != modes) {
    throw FormatError(where(path, "/model/pcaBasis") + ": shape does not match /model/mean (" + std::to_string(dim) +
                      ") x /model/pcaVariance (" + std::to_string(modes) + ")");
  }
  if (d_pts.size() != 2 || d_pts[0] != 3 || static_cast<Eigen::Index>(3 * d_pts[1]) != dim) {
    throw FormatError(where(path, "/representer/points") + ": expected 3 x " + std::to_string(dim / 3) + " points");
  }
  if (d_cells.size() != 2 || d_cells[0] != 3) {
    throw FormatError(where(path, "/representer/cells") + ": expected 3 x M triangle indices");
  }
  if (noise.size() != 1) throw FormatError(where(path, "/model/noiseVariance") + ": expected one value");

  ShapeModel model;
  model.mean = Eigen::Map<const Eigen::VectorXd>(mean.data(), dim);
  // HDF5 stores row-major.
  model.basis = Eigen::Map<const Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>>(basis.data(),
                                                                                                         dim, modes);
  model.variances = Eigen::Map<const Eigen::VectorXd>(var.data(), modes);
  model.noise_variance = noise[0];
  if (hdr.minor_version == 8) {
    // Format 0.8 stored the scaled basis U diag(sqrt(variances)).
    for (Eigen::Index i = 0; i < modes; ++i) {
      if (model.variances[i] > 0.0) model.basis.col(i) /= std::sqrt(model.variances[i]);
    }
  }
  // scalismo writes low-rank Gaussian-process models whose basis columns are
  // Nystrom eigenfunctions (neither unit nor exactly orthogonal). The model's
  // covariance B diag(l) B^T is kept exactly and re-expressed with an
  // orthonormal basis (thin SVD of B diag(sqrt(l))), the convention of format
  // 0.9 and of everything in mrsns::deformation. Bases orthonormal to float32
  // precision are left untouched so that round trips are lossless.
  if (modes > 0) {
    const Eigen::MatrixXd gram = model.basis.transpose() * model.basis;
    if ((gram - Eigen::MatrixXd::Identity(modes, modes)).cwiseAbs().maxCoeff() > 1e-4) {
      const Eigen::MatrixXd scaled = model.basis * model.variances.cwiseMax(0.0).cwiseSqrt().asDiagonal();
      const ThinSvd svd = thinSvd(scaled, SvdVectors::kU);
      model.basis = svd.u;
      model.variances = svd.singular_values.array().square().matrix();
      hdr.basis_orthonormalized = true;
    }
  }
  const auto n_points = static_cast<Eigen::Index>(d_pts[1]);
  const auto n_cells = static_cast<Eigen::Index>(d_cells[1]);
  model.reference.vertices.resize(n_points, 3);
  for (Eigen::Index i = 0; i < n_points; ++i) {
    for (int c = 0; c < 3; ++c) model.reference.vertices(i, c) = pts[static_cast<std::size_t>(c * n_points + i)];
  }
  model.reference.faces.resize(n_cells, 3);
  for (Eigen::Index i = 0; i < n_cells; ++i) {
    for (int c = 0; c < 3; ++c) {
      const int v = cells[static_cast<std::size_t>(c * n_cells + i)];
      if (v >= n_points) {
        throw FormatError(where(path, "/representer/cells") + ": index " + std::to_string(v) + " >= point count " +
                          std::to_string(n_points));
      }
      model.reference.faces(i, c) = v;
    }
  }
  model.reference.name = path.stem().string();
  if (!model.mean.allFinite() || !model.basis.allFinite() || !model.variances.allFinite() ||
      !std::isfinite(model.noise_variance) || !model.reference.vertices.allFinite()) {
    throw FormatError(path.string() + ": model contains NaN or infinite values");
  }
  if (info != nullptr) *info = hdr;
  return model;
}

void writeStatismoModel(const ShapeModel& model, const std::filesystem::path& path,
                        const StatismoWriteOptions& options) {
  silenceHdf5();
  const Eigen::Index dim = model.mean.size();
  const Eigen::Index modes = model.basis.cols();
  if (dim == 0 || dim % 3 != 0 || model.basis.rows() != dim || model.variances.size() != modes ||
      model.reference.vertexCount() != dim / 3 || model.reference.faceCount() == 0) {
    throw InvalidArgumentError("writeStatismoModel(" + path.string() +
                               "): inconsistent model (mean 3N, basis 3N x n, n variances, reference with N "
                               "vertices and faces required)");
  }
  Handle file(H5Fcreate(path.c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, H5P_DEFAULT), H5Fclose);
  if (!file.valid()) throw FileError(path.string() + ": cannot create file; check the directory and permissions");
  const hid_t f = file.get();
  const bool dbl = options.double_precision;
  {
    Handle g = makeGroup(f, "/model", path);
    writeMatrix(g.get(), "mean", model.mean.data(), {static_cast<hsize_t>(dim)}, dbl, path);
    const Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor> b = model.basis;
    writeMatrix(g.get(), "pcaBasis", b.data(), {static_cast<hsize_t>(dim), static_cast<hsize_t>(modes)}, dbl, path);
    writeMatrix(g.get(), "pcaVariance", model.variances.data(), {static_cast<hsize_t>(modes)}, dbl, path);
    writeMatrix(g.get(), "noiseVariance", &model.noise_variance, {1}, dbl, path);
  }
  {
    Handle g = makeGroup(f, "/modelinfo", path);
    const std::string now = nowText();
    writeStringDataset(g.get(), "build-time", now, path);
    Handle b = makeGroup(g.get(), "modelBuilder-0", path);
    writeStringDataset(b.get(), "buildTime", now, path);
    writeStringDataset(b.get(), "builderName", options.builder_name, path);
    Handle d = makeGroup(b.get(), "dataInfo", path);
    Handle p = makeGroup(b.get(), "parameters", path);
  }
  {
    Handle g = makeGroup(f, "/representer", path);
    writeStringAttribute(g.get(), "name", options.representer_name, path);
    writeStringAttribute(g.get(), "datasetType", "POLYGON_MESH", path);
    writeStringAttribute(g.get(), "version/majorVersion", "0", path);
    writeStringAttribute(g.get(), "version/minorVersion", "9", path);
    const Eigen::Index n = model.reference.vertexCount();
    const Eigen::Index m = model.reference.faceCount();
    const Eigen::Matrix<double, 3, Eigen::Dynamic, Eigen::RowMajor> pts = model.reference.vertices.transpose();
    writeMatrix(g.get(), "points", pts.data(), {3, static_cast<hsize_t>(n)}, dbl, path);
    const Eigen::Matrix<int, 3, Eigen::Dynamic, Eigen::RowMajor> cells = model.reference.faces.transpose().cast<int>();
    writeInts(g.get(), "cells", cells.data(), {3, static_cast<hsize_t>(m)}, path);
  }
  {
    Handle g = makeGroup(f, "/version", path);
    const int major = 0;
    const int minor = 9;
    writeInts(g.get(), "majorVersion", &major, {}, path);
    writeInts(g.get(), "minorVersion", &minor, {}, path);
  }
  if (H5Fflush(f, H5F_SCOPE_GLOBAL) < 0) throw FileError(path.string() + ": cannot flush HDF5 file");
}

}  // namespace mrsns::io
