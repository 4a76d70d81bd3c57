#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <Eigen/SVD>
#include <filesystem>
#include <fstream>
#include <limits>
#include <random>
#include <sstream>

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

// ---- The ChildToParent convention (writeChildToParent / readChildToParent) ----
//
// Checked against 3D Slicer's documented behaviour, implemented here without
// the library's helpers: Slicer saves a linear transform node by converting its
// ToParent from RAS to LPS and writing the inverse (ITK's resampling
// direction) as an ITK AffineTransform, "Parameters:" the 3x3 row by row then
// the translation, "FixedParameters: 0 0 0"; a plain 4x4 text matrix holds the
// ToParent itself (LPS).

/// F = diag(-1, -1, 1, 1): RAS <-> LPS.
Eigen::Matrix4d conventionRasLpsFlip() {
  return Eigen::Vector4d(-1.0, -1.0, 1.0, 1.0).asDiagonal();
}

/// The affine a Slicer-style ITK text file describes, parsed by hand: the
/// first AffineTransform's "Parameters:" (12 numbers) and "FixedParameters:"
/// (its centre, which must be 0 0 0 as Slicer writes it).
struct ParsedItkAffine {
  std::string transform_class;
  std::vector<double> parameters, fixed_parameters;
  Eigen::Matrix4d matrix = Eigen::Matrix4d::Identity();
};

std::vector<double> conventionNumbers(const std::string& text) {
  std::vector<double> out;
  std::istringstream in(text);
  double v = 0.0;
  while (in >> v) out.push_back(v);
  return out;
}

ParsedItkAffine conventionParseTfm(const std::filesystem::path& path) {
  std::ifstream in(path);
  std::string line;
  ParsedItkAffine parsed;
  EXPECT_TRUE(std::getline(in, line));
  EXPECT_EQ(line.rfind("#Insight Transform File", 0), 0U) << path << ": " << line;
  while (std::getline(in, line)) {
    const auto colon = line.find(':');
    if (colon == std::string::npos) continue;
    const std::string key = line.substr(0, colon), rest = line.substr(colon + 1);
    if (key == "Transform") {
      std::istringstream(rest) >> parsed.transform_class;
    } else if (key == "Parameters") {
      parsed.parameters = conventionNumbers(rest);
    } else if (key == "FixedParameters") {
      parsed.fixed_parameters = conventionNumbers(rest);
    }
  }
  EXPECT_EQ(parsed.parameters.size(), 12U) << path;
  EXPECT_EQ(parsed.fixed_parameters.size(), 3U) << path;
  if (parsed.parameters.size() == 12) {
    for (int r = 0; r < 3; ++r) {
      for (int c = 0; c < 3; ++c) parsed.matrix(r, c) = parsed.parameters[static_cast<std::size_t>(3 * r + c)];
      parsed.matrix(r, 3) = parsed.parameters[static_cast<std::size_t>(9 + r)];
    }
  }
  return parsed;
}

/// The 16 numbers of a plain text matrix, parsed by hand.
Eigen::Matrix4d conventionParsePlain(const std::filesystem::path& path) {
  std::ifstream in(path);
  std::stringstream ss;
  ss << in.rdbuf();
  EXPECT_EQ(ss.str().find("Insight"), std::string::npos) << path << " is not a plain matrix";
  const std::vector<double> v = conventionNumbers(ss.str());
  EXPECT_EQ(v.size(), 16U) << path;
  Eigen::Matrix4d m = Eigen::Matrix4d::Identity();
  for (int i = 0; i < 16 && i < static_cast<int>(v.size()); ++i) m(i / 4, i % 4) = v[static_cast<std::size_t>(i)];
  return m;
}

/// ImageToProbe-like affines (mm/pixel scaling 0.08-0.2, a shear) and a rotation with anisotropic scale.
std::vector<Eigen::Matrix4d> affineSamples() {
  std::vector<Eigen::Matrix4d> out;
  Eigen::Matrix4d image_to_probe = rigid(0.7, Eigen::Vector3d(0.2, -1, 0.4), Eigen::Vector3d(-35.5, 12.25, 48));
  image_to_probe.topLeftCorner<3, 3>() *= Eigen::Vector3d(0.0833, 0.0917, 1.0).asDiagonal();
  out.push_back(image_to_probe);
  Eigen::Matrix4d sheared = rigid(2.2, Eigen::Vector3d(1, 1, 1), Eigen::Vector3d(120, -80, 300));
  Eigen::Matrix3d shear = Eigen::Matrix3d::Identity();
  shear(0, 1) = 0.3;
  shear(2, 0) = -0.1;
  sheared.topLeftCorner<3, 3>() = sheared.topLeftCorner<3, 3>() * shear * Eigen::Vector3d(0.2, 0.15, 1.5).asDiagonal();
  out.push_back(sheared);
  return out;
}

/// Tolerance for a matrix that went through inversions and a decimal round
/// trip in double precision: the error of inverting A is ~ cond(A) eps per
/// unit entry, so allow 64 ulps of the largest entry times the condition
/// number (two inversions of a few ulps each, with margin).
double conventionTolerance(const Eigen::Matrix4d& m) {
  const Eigen::Vector3d s =
      Eigen::JacobiSVD<Eigen::Matrix3d>(Eigen::Matrix3d(m.topLeftCorner<3, 3>())).singularValues();
  const double condition = s.x() / s.z();
  const double scale = std::max({1.0, m.cwiseAbs().maxCoeff(), m.inverse().cwiseAbs().maxCoeff()});
  return 64.0 * std::numeric_limits<double>::epsilon() * condition * condition * scale;
}

TEST(TransformIoChildToParent, EveryFormatRoundTripsRigidAndAffine) {
  const auto dir = test::scratchDirectory("c2p");
  std::vector<Eigen::Matrix4d> samples = rigidSamples();
  for (const auto& a : affineSamples()) samples.push_back(a);
  int n = 0;
  for (const Eigen::Matrix4d& parent_T_child : samples) {
    const double tolerance = conventionTolerance(parent_T_child);
    for (const std::string ext : {".tfm", ".h5", ".hdf5", ".mat", ".txt"}) {
      SCOPED_TRACE(std::to_string(n) + ext);
      const auto file = dir / ("ChildToParent" + std::to_string(n) + ext);
      writeChildToParent(parent_T_child, file);
      const Eigen::Matrix4d back = readChildToParent(file);
      EXPECT_LT((back - parent_T_child).cwiseAbs().maxCoeff(), tolerance);
      // What the file holds, by the raw API: the inverse for ITK formats, the matrix itself in a .txt.
      const TransformFile raw = readTransformFile(file);
      const Eigen::Matrix4d expected_raw = ext == ".txt" ? parent_T_child : Eigen::Matrix4d(parent_T_child.inverse());
      EXPECT_LT((raw.matrix - expected_raw).cwiseAbs().maxCoeff(), tolerance);
      const std::string format = ext == ".txt"   ? "matrix-text"
                                 : ext == ".tfm" ? "itk-text"
                                 : ext == ".mat" ? "itk-matlab"
                                                 : "itk-hdf5";
      EXPECT_EQ(raw.format, format);
    }
    // An ITK text file named .txt (as Slicer may save one) is read by its header, as the inverse.
    const auto itk_txt = dir / ("ItkText" + std::to_string(n) + ".txt");
    std::filesystem::copy_file(dir / ("ChildToParent" + std::to_string(n) + ".tfm"), itk_txt);
    EXPECT_EQ(readTransformFile(itk_txt).format, "itk-text");
    EXPECT_LT((readChildToParent(itk_txt) - parent_T_child).cwiseAbs().maxCoeff(), tolerance);
    ++n;
  }
}

TEST(TransformIoChildToParent, ItkFileHoldsTheInverseAsSlicerWritesIt) {
  const auto dir = test::scratchDirectory("c2p");
  std::vector<Eigen::Matrix4d> samples = rigidSamples();
  for (const auto& a : affineSamples()) samples.push_back(a);
  const Eigen::Matrix4d flip = conventionRasLpsFlip();
  int n = 0;
  for (const Eigen::Matrix4d& m : samples) {
    SCOPED_TRACE(n);
    const double tolerance = conventionTolerance(m);
    const auto tfm = dir / ("M" + std::to_string(n) + ".tfm");
    writeChildToParent(m, tfm);
    const ParsedItkAffine parsed = conventionParseTfm(tfm);
    EXPECT_EQ(parsed.transform_class, "AffineTransform_double_3_3");
    EXPECT_EQ(parsed.fixed_parameters, (std::vector<double>{0.0, 0.0, 0.0}));
    // Parameters: the 3x3 of inverse(M) row-major, then its translation.
    const Eigen::Matrix4d inverse = m.inverse();
    EXPECT_LT((parsed.matrix - inverse).cwiseAbs().maxCoeff(), tolerance);
    // What Slicer then shows as the node's ToParent (RAS): F * inverse(file T) * F = F M F.
    const Eigen::Matrix4d slicer_to_parent_ras = flip * parsed.matrix.inverse() * flip;
    EXPECT_LT((slicer_to_parent_ras - flip * m * flip).cwiseAbs().maxCoeff(), tolerance);
    // The plain .txt holds M, row by row.
    const auto txt = dir / ("M" + std::to_string(n) + ".txt");
    writeChildToParent(m, txt);
    EXPECT_LT((conventionParsePlain(txt) - m).cwiseAbs().maxCoeff(),
              4 * std::numeric_limits<double>::epsilon() * std::max(1.0, m.cwiseAbs().maxCoeff()));
    ++n;
  }
}

TEST(TransformIoChildToParent, ReadsWhatSlicerSavesForAKnownNode) {
  // A Slicer node whose ToParent (RAS) turns 90 deg about S and translates by (10, 20, 30) mm.
  // In LPS: M = F ToParent F = [Rz(90) | (-10, -20, 30)]; Slicer's file holds inverse(M) =
  // [Rz(-90) | -Rz(-90) (-10, -20, 30)] = [0 1 0; -1 0 0; 0 0 1 | (20, -10, -30)]. Worked by hand.
  const auto dir = test::scratchDirectory("c2p");
  writeText(dir / "NodeToWorld.tfm",
            "#Insight Transform File V1.0\n#Transform 0\nTransform: AffineTransform_double_3_3\n"
            "Parameters: 0 1 0 -1 0 0 0 0 1 20 -10 -30\nFixedParameters: 0 0 0\n");
  Eigen::Matrix4d m_lps;
  m_lps << 0, -1, 0, -10,  //
      1, 0, 0, -20,        //
      0, 0, 1, 30,         //
      0, 0, 0, 1;
  EXPECT_LT((readChildToParent(dir / "NodeToWorld.tfm") - m_lps).cwiseAbs().maxCoeff(), 1e-15);
  // The rigid reader projects onto a rotation by an SVD: a few ulps.
  const Eigen::Isometry3d rigid_read = readChildToParentRigid(dir / "NodeToWorld.tfm");
  EXPECT_LT((rigid_read.matrix() - m_lps).cwiseAbs().maxCoeff(), 1e-14);
  // A point of the child 1 mm along L lands 1 mm along P from (-10, -20, 30) in the parent.
  const Eigen::Vector3d p_parent = rigid_read * Eigen::Vector3d(1, 0, 0);
  EXPECT_LT((p_parent - Eigen::Vector3d(-10, -19, 30)).norm(), 1e-13);
  // Writing the same node gives Slicer's numbers back.
  writeChildToParent(m_lps, dir / "written.tfm");
  const ParsedItkAffine parsed = conventionParseTfm(dir / "written.tfm");
  const std::vector<double> slicer = {0, 1, 0, -1, 0, 0, 0, 0, 1, 20, -10, -30};
  ASSERT_EQ(parsed.parameters.size(), slicer.size());
  for (std::size_t i = 0; i < slicer.size(); ++i) EXPECT_NEAR(parsed.parameters[i], slicer[i], 1e-15) << i;
  // And a .txt of that node holds M, not the file's inverse: the two files mean the same node.
  writeChildToParent(readChildToParent(dir / "NodeToWorld.tfm"), dir / "NodeToWorld.txt");
  EXPECT_LT((conventionParsePlain(dir / "NodeToWorld.txt") - m_lps).cwiseAbs().maxCoeff(), 1e-15);
}

TEST(TransformIoChildToParent, RefusesWhatHasNoMeaningNamingTheFile) {
  const auto dir = test::scratchDirectory("c2p");
  // A singular affine (a zero scale) cannot go into an ITK file, which holds the inverse.
  Eigen::Matrix4d flat = Eigen::Matrix4d::Identity();
  flat(2, 2) = 0.0;
  try {
    writeChildToParent(flat, dir / "Flat.tfm");
    FAIL() << "a singular matrix was written to an ITK file";
  } catch (const InvalidArgumentError& e) {
    EXPECT_THAT(e.what(), HasSubstr("Flat.tfm"));
    EXPECT_THAT(e.what(), HasSubstr("singular"));
  }
  EXPECT_FALSE(std::filesystem::exists(dir / "Flat.tfm"));
  writeTransformFile(flat, dir / "RawFlat.tfm");  // the raw API writes it as given
  try {
    (void)readChildToParent(dir / "RawFlat.tfm");
    FAIL() << "a singular ITK transform was inverted";
  } catch (const FormatError& e) {
    EXPECT_THAT(e.what(), HasSubstr("RawFlat.tfm"));
  }
  Eigen::Matrix4d nan = Eigen::Matrix4d::Identity();
  nan(1, 3) = std::numeric_limits<double>::quiet_NaN();
  EXPECT_THROW(writeChildToParent(nan, dir / "nan.txt"), InvalidArgumentError);
  Eigen::Matrix4d projective = Eigen::Matrix4d::Identity();
  projective(3, 0) = 0.5;
  EXPECT_THROW(writeChildToParent(projective, dir / "p.tfm"), InvalidArgumentError);
  EXPECT_THROW(writeChildToParent(Eigen::Matrix4d::Identity(), dir / "x.xform"), UnsupportedError);
  // An affine ImageToProbe is not rigid.
  writeChildToParent(affineSamples().front(), dir / "ImageToProbe.tfm");
  try {
    (void)readChildToParentRigid(dir / "ImageToProbe.tfm");
    FAIL() << "a scaled calibration was read as rigid";
  } catch (const UnsupportedError& e) {
    EXPECT_THAT(e.what(), HasSubstr("ImageToProbe.tfm"));
    EXPECT_THAT(e.what(), HasSubstr("not rigid"));
  }
  // A non-linear transform has no matrix.
  std::string params;
  for (int i = 0; i < 3 * 64; ++i) params += " 0";
  writeText(dir / "bspline.tfm",
            "#Insight Transform File V1.0\n#Transform 0\nTransform: BSplineTransform_double_3_3\n"
            "Parameters:" +
                params + "\nFixedParameters: 4 4 4 0 0 0 10 10 10 1 0 0 0 1 0 0 0 1\n");
  EXPECT_THROW((void)readChildToParent(dir / "bspline.tfm"), UnsupportedError);
}

TEST(TransformIoChildToParent, CompositeFileIsTheInverseOfItsComposition) {
  // Slicer writes a composite when a node was hardened from two: the file's T applies the back of the
  // queue first; ChildToParent is inverse(T) = inverse(A * B) with B = translate (5, 0, 0), A = Rz(90).
  const auto dir = test::scratchDirectory("c2p");
  writeText(dir / "composite.tfm",
            "#Insight Transform File V1.0\n#Transform 0\nTransform: CompositeTransform_double_3_3\n"
            "#Transform 1\nTransform: AffineTransform_double_3_3\nParameters: 0 -1 0 1 0 0 0 0 1 0 0 0\n"
            "FixedParameters: 0 0 0\n#Transform 2\nTransform: AffineTransform_double_3_3\n"
            "Parameters: 1 0 0 0 1 0 0 0 1 5 0 0\nFixedParameters: 0 0 0\n");
  // File T maps (1, 0, 0) to (0, 6, 0), so ChildToParent maps (0, 6, 0) back to (1, 0, 0).
  const Eigen::Matrix4d c2p = readChildToParent(dir / "composite.tfm");
  EXPECT_LT((c2p * Eigen::Vector4d(0, 6, 0, 1) - Eigen::Vector4d(1, 0, 0, 1)).norm(), 1e-14);
}

}  // namespace
}  // namespace mrsns::io
