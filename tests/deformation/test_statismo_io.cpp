#include <gtest/gtest.h>
#include <hdf5.h>

#include <fstream>
#include <random>

#include "mrsns/core/error.h"
#include "mrsns/deformation/shape_model_ops.h"
#include "mrsns/io/statismo_io.h"
#include "test_data.h"
#include "test_helpers.h"

namespace mrsns::deformation {
namespace {

TEST(StatismoIo, LoadsScalismoModelSamplesAndProjects) {
  MRSNS_REQUIRE_DATA(path, "ssm/scalismo/model.h5");
  io::StatismoFileInfo info;
  const ShapeModel model = io::readStatismoModel(path, &info);
  EXPECT_EQ(info.major_version, 0);
  EXPECT_EQ(info.minor_version, 9);
  EXPECT_EQ(info.representer_name, "itkStandardMeshRepresenter");
  EXPECT_EQ(info.dataset_type, "POLYGON_MESH");
  ASSERT_EQ(model.pointCount(), 1400);
  ASSERT_EQ(model.modeCount(), 50);
  EXPECT_EQ(model.reference.faceCount(), 2800);
  EXPECT_NO_THROW(validateShapeModel(model));
  // Orthonormal columns to float32 precision (format 0.9 convention).
  const Eigen::MatrixXd gram = model.basis.transpose() * model.basis;
  EXPECT_LT((gram - Eigen::MatrixXd::Identity(50, 50)).cwiseAbs().maxCoeff(), 1e-5);
  EXPECT_GT(model.variances.minCoeff(), 0.0);
  // Sample, then project: the coefficients come back (noise variance is 0 here).
  std::mt19937_64 rng(42);
  Eigen::VectorXd alpha(50);
  std::normal_distribution<double> n(0.0, 1.0);
  for (auto& a : alpha) a = n(rng);
  const Eigen::VectorXd shape = modelInstance(model, alpha);
  // float32 basis: orthonormality error ~1e-6 times |alpha| ~ 7.
  EXPECT_LT((projectShape(model, shape) - alpha).cwiseAbs().maxCoeff(), 1e-3);
  const Eigen::VectorXd random = sampleShape(model, rng);
  EXPECT_GT(meanVertexDistance(random, model.mean), 0.1);
  EXPECT_LT(shapeMahalanobisDistance(model, random), 7.07 + 6.0);  // chi(50): mean 7.07, sd 0.71
}

TEST(StatismoIo, RealModelKeepsItsCovarianceAndRoundTripsLosslessly) {
  MRSNS_REQUIRE_DATA(path, "ssm/scalismo/model.h5");
  io::StatismoFileInfo info;
  const ShapeModel model = io::readStatismoModel(path, &info);
  // scalismo's Gaussian-process basis is not orthonormal: re-expressed, with
  // the covariance at a vertex equal to the file's B diag(l) B^T block.
  EXPECT_TRUE(info.basis_orthonormalized);
  const hid_t f = H5Fopen(path.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
  ASSERT_GE(f, 0);
  Eigen::Matrix<float, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor> raw_basis(4200, 50);
  Eigen::VectorXf raw_var(50);
  const hid_t b = H5Dopen2(f, "/model/pcaBasis", H5P_DEFAULT);
  H5Dread(b, H5T_NATIVE_FLOAT, H5S_ALL, H5S_ALL, H5P_DEFAULT, raw_basis.data());
  H5Dclose(b);
  const hid_t v = H5Dopen2(f, "/model/pcaVariance", H5P_DEFAULT);
  H5Dread(v, H5T_NATIVE_FLOAT, H5S_ALL, H5S_ALL, H5P_DEFAULT, raw_var.data());
  H5Dclose(v);
  H5Fclose(f);
  for (const Eigen::Index vertex : {0, 700, 1399}) {
    const Eigen::MatrixXd rb = raw_basis.middleRows(3 * vertex, 3).cast<double>();
    const Eigen::Matrix3d file_cov = rb * raw_var.cast<double>().asDiagonal() * rb.transpose();
    const Eigen::MatrixXd q = model.basis.middleRows(3 * vertex, 3);
    const Eigen::Matrix3d cov = q * model.variances.asDiagonal() * q.transpose();
    EXPECT_LT((cov - file_cov).cwiseAbs().maxCoeff(), 1e-9 * file_cov.cwiseAbs().maxCoeff() + 1e-12) << vertex;
  }
  const auto dir = test::scratchDirectory("statismo_io_real");
  // Double precision: bit-exact.
  io::StatismoWriteOptions dbl;
  dbl.double_precision = true;
  io::writeStatismoModel(model, dir / "double.h5", dbl);
  const ShapeModel d = io::readStatismoModel(dir / "double.h5");
  EXPECT_EQ(d.mean, model.mean);
  EXPECT_EQ(d.basis, model.basis);
  EXPECT_EQ(d.variances, model.variances);
  // float32 as statismo writes: float rounding once, then lossless.
  io::writeStatismoModel(model, dir / "a.h5");
  io::StatismoFileInfo info_a;
  const ShapeModel a = io::readStatismoModel(dir / "a.h5", &info_a);
  EXPECT_FALSE(info_a.basis_orthonormalized);
  EXPECT_LT((a.basis - model.basis).cwiseAbs().maxCoeff(), 1e-6);
  io::writeStatismoModel(a, dir / "b.h5");
  const ShapeModel back = io::readStatismoModel(dir / "b.h5");
  EXPECT_EQ(back.mean, a.mean);
  EXPECT_EQ(back.basis, a.basis);
  EXPECT_EQ(back.variances, a.variances);
  EXPECT_EQ(back.noise_variance, a.noise_variance);
  EXPECT_EQ(back.reference.vertices, a.reference.vertices);
  EXPECT_EQ(back.reference.faces, a.reference.faces);
}

TEST(StatismoIo, DoublePrecisionRoundTripIsBitExact) {
  std::mt19937_64 rng(9);
  ShapeModel model = testing::randomModel(30, Eigen::Vector3d(5.0, 2.0, 0.5), rng, 0.1);
  const auto out = test::scratchDirectory("statismo_io") / "double.h5";
  io::StatismoWriteOptions opts;
  opts.double_precision = true;
  io::writeStatismoModel(model, out, opts);
  const ShapeModel back = io::readStatismoModel(out);
  EXPECT_EQ(back.mean, model.mean);
  EXPECT_EQ(back.basis, model.basis);
  EXPECT_EQ(back.variances, model.variances);
  EXPECT_EQ(back.noise_variance, model.noise_variance);
  EXPECT_EQ(back.reference.vertices, model.reference.vertices);
  EXPECT_EQ(back.reference.faces, model.reference.faces);
}

// Reads a dataset's class, element size and dims for the layout check.
struct DatasetShape {
  H5T_class_t cls = H5T_NO_CLASS;
  std::size_t size = 0;
  std::vector<hsize_t> dims;
  bool scalar = false;
};

DatasetShape datasetShape(hid_t f, const char* name) {
  DatasetShape s;
  const hid_t ds = H5Dopen2(f, name, H5P_DEFAULT);
  if (ds < 0) return s;
  const hid_t t = H5Dget_type(ds);
  s.cls = H5Tget_class(t);
  s.size = H5Tget_size(t);
  const hid_t sp = H5Dget_space(ds);
  s.scalar = H5Sget_simple_extent_type(sp) == H5S_SCALAR;
  s.dims.resize(static_cast<std::size_t>(H5Sget_simple_extent_ndims(sp)));
  H5Sget_simple_extent_dims(sp, s.dims.data(), nullptr);
  H5Sclose(sp);
  H5Tclose(t);
  H5Dclose(ds);
  return s;
}

TEST(StatismoIo, WrittenFileHasStatismoLayout) {
  std::mt19937_64 rng(10);
  const ShapeModel model = testing::randomModel(40, Eigen::Vector3d(5.0, 2.0, 0.5), rng);
  const auto out = test::scratchDirectory("statismo_io") / "layout.h5";
  io::writeStatismoModel(model, out);
  const hid_t f = H5Fopen(out.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
  ASSERT_GE(f, 0);
  using V = std::vector<hsize_t>;
  // The layout of scalismo's model.h5 (statismo 0.9): float32 model, 3 x N points, 3 x M int32 cells.
  const auto mean = datasetShape(f, "/model/mean");
  EXPECT_EQ(mean.cls, H5T_FLOAT);
  EXPECT_EQ(mean.size, 4u);
  EXPECT_EQ(mean.dims, V({120}));
  EXPECT_EQ(datasetShape(f, "/model/pcaBasis").dims, V({120, 3}));
  EXPECT_EQ(datasetShape(f, "/model/pcaVariance").dims, V({3}));
  EXPECT_EQ(datasetShape(f, "/model/noiseVariance").dims, V({1}));
  EXPECT_EQ(datasetShape(f, "/representer/points").dims, V({3, 40}));
  const auto cells = datasetShape(f, "/representer/cells");
  EXPECT_EQ(cells.cls, H5T_INTEGER);
  EXPECT_EQ(cells.dims, V({3, 38}));
  const auto major = datasetShape(f, "/version/majorVersion");
  EXPECT_TRUE(major.scalar);
  EXPECT_EQ(major.cls, H5T_INTEGER);
  EXPECT_TRUE(datasetShape(f, "/version/minorVersion").scalar);
  EXPECT_EQ(datasetShape(f, "/modelinfo/build-time").cls, H5T_STRING);
  EXPECT_EQ(datasetShape(f, "/modelinfo/modelBuilder-0/builderName").cls, H5T_STRING);
  const hid_t rep = H5Gopen2(f, "/representer", H5P_DEFAULT);
  for (const char* a : {"name", "datasetType", "version/majorVersion", "version/minorVersion"}) {
    EXPECT_GT(H5Aexists(rep, a), 0) << a;
  }
  H5Gclose(rep);
  H5Fclose(f);
  io::StatismoFileInfo info;
  (void)io::readStatismoModel(out, &info);
  EXPECT_EQ(info.minor_version, 9);
  EXPECT_EQ(info.dataset_type, "POLYGON_MESH");
  EXPECT_EQ(info.representer_name, "itkStandardMeshRepresenter");
}

TEST(StatismoIo, CorruptAndForeignFilesGiveClearErrors) {
  const auto dir = test::scratchDirectory("statismo_io");
  EXPECT_THROW((void)io::readStatismoModel(dir / "missing.h5"), FileError);
  { std::ofstream(dir / "text.h5") << "this is not HDF5"; }
  EXPECT_THROW((void)io::readStatismoModel(dir / "text.h5"), FormatError);
  // A foreign HDF5 file: valid HDF5 without statismo's groups.
  {
    const hid_t f = H5Fcreate((dir / "foreign.h5").c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, H5P_DEFAULT);
    const hid_t g = H5Gcreate2(f, "/images", H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT);
    H5Gclose(g);
    H5Fclose(f);
  }
  try {
    (void)io::readStatismoModel(dir / "foreign.h5");
    FAIL() << "expected FormatError";
  } catch (const FormatError& e) {
    EXPECT_NE(std::string(e.what()).find("foreign.h5"), std::string::npos);
    EXPECT_NE(std::string(e.what()).find("statismo"), std::string::npos);
  }
  // A statismo file with a dataset removed, and a truncated one.
  std::mt19937_64 rng(12);
  const ShapeModel model = testing::randomModel(20, Eigen::Vector2d(2.0, 1.0), rng);
  io::writeStatismoModel(model, dir / "partial.h5");
  {
    const hid_t f = H5Fopen((dir / "partial.h5").c_str(), H5F_ACC_RDWR, H5P_DEFAULT);
    H5Ldelete(f, "/model/pcaBasis", H5P_DEFAULT);
    H5Fclose(f);
  }
  try {
    (void)io::readStatismoModel(dir / "partial.h5");
    FAIL() << "expected FormatError";
  } catch (const FormatError& e) {
    EXPECT_NE(std::string(e.what()).find("/model/pcaBasis"), std::string::npos);
  }
  io::writeStatismoModel(model, dir / "full.h5");
  {
    std::ifstream in(dir / "full.h5", std::ios::binary);
    std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    std::ofstream(dir / "truncated.h5", std::ios::binary) << bytes.substr(0, bytes.size() / 2);
  }
  EXPECT_THROW((void)io::readStatismoModel(dir / "truncated.h5"), FormatError);
}

}  // namespace
}  // namespace mrsns::deformation
