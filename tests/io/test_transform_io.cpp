#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <fstream>
#include <random>

#include "mrsns/core/error.h"
#include "mrsns/io/transform_io.h"
#include "test_data.h"

namespace mrsns::io {
namespace {

using ::testing::HasSubstr;

void writeText(const std::filesystem::path& path, const std::string& text) {
  std::ofstream out(path, std::ios::binary);
  out << text;
}

Eigen::Matrix4d rigid(double angle, const Eigen::Vector3d& axis, const Eigen::Vector3d& t) {
  Eigen::Matrix4d m = Eigen::Matrix4d::Identity();
  m.topLeftCorner<3, 3>() = Eigen::AngleAxisd(angle, axis.normalized()).toRotationMatrix();
  m.topRightCorner<3, 1>() = t;
  return m;
}

/// Identity, tiny, near-pi and random rotations with translations.
std::vector<Eigen::Matrix4d> rigidSamples() {
  std::vector<Eigen::Matrix4d> out = {Eigen::Matrix4d::Identity(),
                                      rigid(1e-9, Eigen::Vector3d(0, 0, 1), Eigen::Vector3d(1e-6, 0, 0)),
                                      rigid(M_PI - 1e-7, Eigen::Vector3d(1, 1, 0), Eigen::Vector3d(-400, 250, 1000))};
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  for (int i = 0; i < 5; ++i) {
    out.push_back(rigid(3.0 * u(rng), Eigen::Vector3d(u(rng), u(rng), u(rng)),
                        Eigen::Vector3d(300 * u(rng), 300 * u(rng), 300 * u(rng))));
  }
  return out;
}

TEST(TransformIo, RigidRoundTripEveryFormat) {
  const auto dir = test::scratchDirectory("tfm");
  int n = 0;
  for (const Eigen::Matrix4d& t : rigidSamples()) {
    for (const std::string ext : {".tfm", ".h5", ".mat", ".txt"}) {
      SCOPED_TRACE(std::to_string(n) + ext);
      std::string name = "t";
      name += std::to_string(n);
      name += ext;
      const auto file = dir / name;
      writeTransformFile(t, file);
      const TransformFile read = readTransformFile(file);
      EXPECT_TRUE(read.linear);
      EXPECT_TRUE(read.rigid);
      // Written in full double precision: a few ulps of 1000 mm.
      EXPECT_LT((read.matrix - t).cwiseAbs().maxCoeff(), 1e-12);
      const Eigen::Isometry3d iso = readRigidTransform(file);
      EXPECT_LT((iso.matrix() - t).cwiseAbs().maxCoeff(), 1e-12);
      EXPECT_NEAR((iso.linear().transpose() * iso.linear() - Eigen::Matrix3d::Identity()).norm(), 0.0, 1e-14);
    }
    ++n;
  }
  EXPECT_EQ(readTransformFile(dir / "t0.tfm").format, "itk-text");
  EXPECT_EQ(readTransformFile(dir / "t0.h5").format, "itk-hdf5");
  EXPECT_EQ(readTransformFile(dir / "t0.mat").format, "itk-matlab");
  EXPECT_EQ(readTransformFile(dir / "t0.txt").format, "matrix-text");
}

TEST(TransformIo, AffineWithCenterFromSlicerStyleTfm) {
  const auto dir = test::scratchDirectory("tfm");
  // ITK: T(x) = M (x - c) + c + t; Parameters = M row-major then t; FixedParameters = c.
  writeText(dir / "affine.tfm",
            "#Insight Transform File V1.0\n#Transform 0\nTransform: AffineTransform_double_3_3\n"
            "Parameters: 2 0 0 0 1 0.5 0 0 1 10 20 30\nFixedParameters: 1 2 3\n");
  const TransformFile read = readTransformFile(dir / "affine.tfm");
  Eigen::Matrix3d m;
  m << 2, 0, 0, 0, 1, 0.5, 0, 0, 1;
  const Eigen::Vector3d c(1, 2, 3), t(10, 20, 30);
  ASSERT_TRUE(read.linear);
  EXPECT_FALSE(read.rigid);
  EXPECT_GT(read.orthonormality_error, 1.0);
  EXPECT_LT((read.matrix.topLeftCorner<3, 3>() - m).norm(), 1e-15);
  EXPECT_LT((read.matrix.topRightCorner<3, 1>() - (t + c - m * c)).norm(), 1e-12);
  try {
    (void)readRigidTransform(dir / "affine.tfm");
    FAIL() << "a scaling transform was accepted as rigid";
  } catch (const UnsupportedError& e) {
    EXPECT_THAT(e.what(), HasSubstr("affine.tfm"));
    EXPECT_THAT(e.what(), HasSubstr("not rigid"));
  }
}

TEST(TransformIo, EulerAndFloatTransformsAreRead) {
  const auto dir = test::scratchDirectory("tfm");
  // Euler3DTransform: angles (x, y, z) in radians then translation; default ZXY order: R = Rz Rx Ry.
  writeText(dir / "euler.tfm",
            "#Insight Transform File V1.0\n#Transform 0\nTransform: Euler3DTransform_double_3_3\n"
            "Parameters: 0.1 -0.2 0.3 5 6 7\nFixedParameters: 0 0 0 0\n");
  const Eigen::Matrix3d r =
      (Eigen::AngleAxisd(0.3, Eigen::Vector3d::UnitZ()) * Eigen::AngleAxisd(0.1, Eigen::Vector3d::UnitX()) *
       Eigen::AngleAxisd(-0.2, Eigen::Vector3d::UnitY()))
          .toRotationMatrix();
  const Eigen::Isometry3d euler = readRigidTransform(dir / "euler.tfm");
  EXPECT_LT((euler.linear() - r).norm(), 1e-12);
  EXPECT_LT((euler.translation() - Eigen::Vector3d(5, 6, 7)).norm(), 1e-12);
  // float precision files (Slicer writes these too).
  writeText(dir / "float.tfm",
            "#Insight Transform File V1.0\n#Transform 0\nTransform: AffineTransform_float_3_3\n"
            "Parameters: 1 0 0 0 1 0 0 0 1 -1.5 2.5 3\nFixedParameters: 0 0 0\n");
  const TransformFile f = readTransformFile(dir / "float.tfm");
  EXPECT_TRUE(f.rigid);
  EXPECT_LT((f.matrix.topRightCorner<3, 1>() - Eigen::Vector3d(-1.5, 2.5, 3)).norm(), 1e-6);
}

TEST(TransformIo, FloatRoundedRotationsAreRigidReflectionsAreNot) {
  const auto dir = test::scratchDirectory("tfm");
  for (const Eigen::Matrix4d& t : rigidSamples()) {
    // Rounded to float (~6e-8 relative), as single-precision tools write them: still rigid.
    const Eigen::Matrix4d rounded = t.cast<float>().cast<double>();
    writeTransformFile(rounded, dir / "f.txt");
    const TransformFile read = readTransformFile(dir / "f.txt");
    EXPECT_TRUE(read.rigid) << read.orthonormality_error;
    const Eigen::Isometry3d iso = readRigidTransform(dir / "f.txt");
    EXPECT_LT((iso.linear().transpose() * iso.linear() - Eigen::Matrix3d::Identity()).norm(), 1e-14);
    EXPECT_LT((iso.matrix() - rounded).cwiseAbs().maxCoeff(), 1e-6);
  }
  Eigen::Matrix4d mirror = Eigen::Matrix4d::Identity();
  mirror(0, 0) = -1.0;
  writeTransformFile(mirror, dir / "mirror.tfm");
  const TransformFile read = readTransformFile(dir / "mirror.tfm");
  EXPECT_TRUE(read.linear);
  EXPECT_NEAR(read.orthonormality_error, 0.0, 1e-15);
  EXPECT_FALSE(read.rigid);  // a reflection is orthonormal but not a rotation
  EXPECT_THROW((void)readRigidTransform(dir / "mirror.tfm"), UnsupportedError);
}

TEST(TransformIo, SlicerConventionHelpers) {
  // A Slicer node translating children by (10, 20, 30) mm in RAS (ToParent)
  // is saved as its inverse in LPS: translation (10, 20, -30).
  Eigen::Matrix4d to_parent_ras = Eigen::Matrix4d::Identity();
  to_parent_ras.topRightCorner<3, 1>() = Eigen::Vector3d(10, 20, 30);
  const Eigen::Matrix4d file_t = fileTransformFromSlicerToParentRas(to_parent_ras);
  EXPECT_LT((file_t.topRightCorner<3, 1>() - Eigen::Vector3d(10, 20, -30)).norm(), 1e-12);
  for (const Eigen::Matrix4d& m : rigidSamples()) {
    EXPECT_LT((slicerToParentRas(fileTransformFromSlicerToParentRas(m)) - m).norm(), 1e-9);
    EXPECT_LT((flipRasLps(flipRasLps(m)) - m).norm(), 1e-15);
    EXPECT_LT((parentFromChildLps(m) * m - Eigen::Matrix4d::Identity()).norm(), 1e-9);
    // A point p_child maps to the parent by the inverse of the file's T, whatever the frame names.
    const Eigen::Vector4d p(1, -2, 3, 1);
    EXPECT_LT((parentFromChildLps(m) * (m * p) - p).norm(), 1e-9);
  }
}

TEST(TransformIo, NonLinearTransformsAreFlaggedAndRefusedByMatrixApis) {
  const auto dir = test::scratchDirectory("tfm");
  // A 4x4x4 B-spline grid: FixedParameters = size(3), origin(3), spacing(3), direction(9).
  std::string params;
  for (int i = 0; i < 3 * 64; ++i) params += (i == 5 ? " 1.5" : " 0");
  std::string text = "#Insight Transform File V1.0\n#Transform 0\nTransform: BSplineTransform_double_3_3\nParameters:";
  text += params;
  text += "\nFixedParameters: 4 4 4 0 0 0 10 10 10 1 0 0 0 1 0 0 0 1\n";
  writeText(dir / "bspline.tfm", text);
  const TransformFile read = readTransformFile(dir / "bspline.tfm");
  EXPECT_FALSE(read.linear);
  EXPECT_FALSE(read.rigid);
  ASSERT_EQ(read.components.size(), 1U);
  EXPECT_THAT(read.components[0], HasSubstr("BSplineTransform"));
  try {
    (void)readLinearTransform(dir / "bspline.tfm");
    FAIL() << "a B-spline was returned as a matrix";
  } catch (const UnsupportedError& e) {
    EXPECT_THAT(e.what(), HasSubstr("bspline.tfm"));
    EXPECT_THAT(e.what(), HasSubstr("BSplineTransform"));
  }
  EXPECT_THROW((void)readRigidTransform(dir / "bspline.tfm"), UnsupportedError);
}

TEST(TransformIo, CompositeOfLinearTransformsIsComposedInApplicationOrder) {
  const auto dir = test::scratchDirectory("tfm");
  // ITK text of a composite: the queue is listed front to back; the back is applied first.
  writeText(dir / "composite.tfm",
            "#Insight Transform File V1.0\n#Transform 0\nTransform: CompositeTransform_double_3_3\n"
            "#Transform 1\nTransform: AffineTransform_double_3_3\nParameters: 0 -1 0 1 0 0 0 0 1 0 0 0\n"
            "FixedParameters: 0 0 0\n#Transform 2\nTransform: AffineTransform_double_3_3\n"
            "Parameters: 1 0 0 0 1 0 0 0 1 5 0 0\nFixedParameters: 0 0 0\n");
  const TransformFile read = readTransformFile(dir / "composite.tfm");
  ASSERT_EQ(read.components.size(), 2U);
  ASSERT_TRUE(read.linear);
  // Translate (5,0,0) first, then rotate 90 deg about z: (1,0,0) -> (6,0,0) -> (0,6,0).
  const Eigen::Vector4d p = read.matrix * Eigen::Vector4d(1, 0, 0, 1);
  EXPECT_LT((p - Eigen::Vector4d(0, 6, 0, 1)).norm(), 1e-12);
}

TEST(TransformIo, MalformedFilesGiveFormatErrorsNamingTheFile) {
  const auto dir = test::scratchDirectory("tfm");
  const std::vector<std::pair<std::string, std::string>> cases = {
      {"garbage.tfm", "hello world\n"},
      {"bad_params.tfm",
       "#Insight Transform File V1.0\n#Transform 0\nTransform: AffineTransform_double_3_3\nParameters: 1 2 3\n"
       "FixedParameters: 0 0 0\n"},
      {"short_params_no_fixed.tfm",
       "#Insight Transform File V1.0\n#Transform 0\nTransform: AffineTransform_double_3_3\nParameters: 1\n"},
      {"unknown_class.tfm",
       "#Insight Transform File V1.0\n#Transform 0\nTransform: NoSuchTransform_double_3_3\nParameters: 1\n"},
      {"fifteen.txt", "1 0 0 0\n0 1 0 0\n0 0 1 0\n0 0 0\n"},
      {"projective.txt", "1 0 0 0\n0 1 0 0\n0 0 1 0\n0 0.5 0 1\n"},
      {"words.txt", "1 0 0 0\n0 one 0 0\n0 0 1 0\n0 0 0 1\n"},
      {"garbage.h5", "not hdf5 at all"},
  };
  for (const auto& [name, text] : cases) {
    writeText(dir / name, text);
    try {
      (void)readTransformFile(dir / name);
      ADD_FAILURE() << name << " was accepted";
    } catch (const FormatError& e) {
      EXPECT_THAT(e.what(), HasSubstr(name));
    } catch (const std::exception& e) {
      ADD_FAILURE() << name << ": wrong exception type: " << e.what();
    }
  }
  EXPECT_THROW((void)readTransformFile(dir / "missing.tfm"), FileError);
  EXPECT_THROW((void)readTransformFile(dir / "x.xform"), UnsupportedError);
  Eigen::Matrix4d nan = Eigen::Matrix4d::Identity();
  nan(0, 3) = std::numeric_limits<double>::quiet_NaN();
  EXPECT_THROW(writeTransformFile(nan, dir / "nan.tfm"), InvalidArgumentError);
}

}  // namespace
}  // namespace mrsns::io
