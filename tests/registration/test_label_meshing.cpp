// Label maps to meshes: analytic volumes and positions on oblique mirrored
// grids, decimation, names, and real vertebra label maps (TotalSegmentator,
// VerSe).
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>
#include <fstream>
#include <iostream>
#include <nlohmann/json.hpp>
#include <numbers>

#include "ct_test_images.h"
#include "mrsns/core/error.h"
#include "mrsns/core/mesh_ops.h"
#include "mrsns/io/image_io.h"
#include "mrsns/registration/label_meshing.h"
#include "test_data.h"

namespace mrsns::registration {
namespace {

/// Centroid of the volume enclosed by a closed mesh (tetrahedra from the origin).
Eigen::Vector3d volumeCentroid(const TriangleMesh& mesh) {
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  double volume = 0.0;
  for (Eigen::Index f = 0; f < mesh.faceCount(); ++f) {
    const Eigen::Vector3d a = mesh.vertices.row(mesh.faces(f, 0));
    const Eigen::Vector3d b = mesh.vertices.row(mesh.faces(f, 1));
    const Eigen::Vector3d c = mesh.vertices.row(mesh.faces(f, 2));
    const double v = a.dot(b.cross(c)) / 6.0;
    sum += v * (a + b + c) / 4.0;
    volume += v;
  }
  return sum / volume;
}

struct SphereCase {
  Eigen::Vector3d center{-30.0, 12.0, 55.0};
  double radius = 10.0;
  ImageVolume labels;
};

SphereCase obliqueSphere(int label) {
  SphereCase s;
  const Eigen::Vector3d spacing(0.8, 1.0, 1.2);
  const Eigen::Matrix3d direction = test::obliqueMirroredDirection();
  const std::array<int, 3> size{36, 30, 26};
  // Put the sphere in the middle of the grid: origin = centre - direction * spacing * (size - 1) / 2.
  const Eigen::Vector3d half = spacing.cwiseProduct(Eigen::Vector3d(size[0] - 1, size[1] - 1, size[2] - 1)) / 2.0;
  const Eigen::Vector3d origin = s.center - direction * half;
  s.labels = test::paintVolume(size, spacing, origin, direction, PixelType::UInt8,
                               [&](const Eigen::Vector3d& p) { return (p - s.center).norm() <= s.radius ? label : 0; });
  return s;
}

// Discretisation bound used throughout: a voxelised surface lies within half
// the largest voxel edge h of the true one, so |V_mesh - V_true| <= A h / 2.
TEST(LabelMeshing, SphereOnObliqueMirroredGridHasAnalyticVolumeAndPlace) {
  const SphereCase s = obliqueSphere(7);
  const auto result = meshLabelMap(s.labels);
  ASSERT_EQ(result.meshes.size(), 1U);
  const LabelMesh& m = result.meshes[0];
  EXPECT_EQ(m.label, 7);
  EXPECT_TRUE(m.closed);
  const double h = 1.2;
  const double area = 4.0 * std::numbers::pi * s.radius * s.radius;
  const double exact_ml = 4.0 / 3.0 * std::numbers::pi * std::pow(s.radius, 3) / 1000.0;
  EXPECT_NEAR(m.mesh_volume_ml, exact_ml, area * h / 2.0 / 1000.0);
  EXPECT_NEAR(m.voxel_volume_ml, exact_ml, area * h / 2.0 / 1000.0);
  EXPECT_NEAR(m.mesh_volume_ml, m.voxel_volume_ml, m.volume_tolerance_ml);
  EXPECT_GT(signedVolume(m.mesh), 0.0) << "faces must point outwards even with a mirrored direction";
  // Every vertex within one voxel of the true sphere, in LPS.
  for (Eigen::Index v = 0; v < m.mesh.vertexCount(); ++v) {
    const double r = (Eigen::Vector3d(m.mesh.vertices.row(v)) - s.center).norm();
    ASSERT_NEAR(r, s.radius, h) << "vertex " << v;
  }
  EXPECT_LT((volumeCentroid(m.mesh) - s.center).norm(), 0.25 * h);
  // Normals point away from the centre.
  ASSERT_EQ(m.mesh.normals.rows(), m.mesh.vertexCount());
  double outward = 0.0;
  for (Eigen::Index v = 0; v < m.mesh.vertexCount(); ++v) {
    outward += m.mesh.normals.row(v).dot((m.mesh.vertices.row(v) - s.center.transpose()).normalized());
  }
  EXPECT_GT(outward / static_cast<double>(m.mesh.vertexCount()), 0.95);
}

TEST(LabelMeshing, UnsmoothedBoxTouchingTheImageEdgeIsClosedAndBounded) {
  // A 10 x 8 x 6 voxel box in the corner of the grid: the one-voxel padding
  // must close it; without smoothing its faces lie half a voxel outside the
  // outer voxel centres.
  const Eigen::Vector3d spacing(0.5, 0.7, 2.0);
  const Eigen::Vector3d origin(100.0, -40.0, 7.0);
  const auto labels = test::paintVolume({20, 20, 12}, spacing, origin, Eigen::Matrix3d::Identity(), PixelType::UInt8,
                                        [&](const Eigen::Vector3d& p) {
                                          const Eigen::Vector3d ijk = (p - origin).cwiseQuotient(spacing);
                                          return ijk.x() < 9.5 && ijk.y() < 7.5 && ijk.z() < 5.5 ? 2 : 0;
                                        });
  LabelMeshOptions options;
  options.smoothing_iterations = 0;
  const auto result = meshLabelMap(labels, options);
  ASSERT_EQ(result.meshes.size(), 1U);
  const auto& m = result.meshes[0];
  EXPECT_TRUE(m.closed);
  const Eigen::AlignedBox3d box = boundingBox(m.mesh);
  const Eigen::Vector3d lo = origin - spacing / 2.0;
  const Eigen::Vector3d hi = origin + spacing.cwiseProduct(Eigen::Vector3d(9.5, 7.5, 5.5));
  EXPECT_LT((box.min() - lo).cwiseAbs().maxCoeff(), 1e-4) << "VTK points are float";
  EXPECT_LT((box.max() - hi).cwiseAbs().maxCoeff(), 1e-4);
  // Flying edges cut the box's edges and corners by half-voxel chamfers: volume within A h / 2.
  const double exact_ml = 10 * 8 * 6 * spacing.prod() / 1000.0;
  EXPECT_NEAR(m.voxel_volume_ml, exact_ml, 1e-12);
  EXPECT_LT(m.mesh_volume_ml, exact_ml);
  EXPECT_NEAR(m.mesh_volume_ml, exact_ml, m.volume_tolerance_ml);
}

TEST(LabelMeshing, DecimationReachesTheTargetAndKeepsTheVolume) {
  const SphereCase s = obliqueSphere(1);
  LabelMeshOptions options;
  options.target_triangles = 500;
  const auto result = meshLabelMap(s.labels, options);
  const auto& m = result.meshes.at(0);
  EXPECT_GT(m.triangles_before_decimation, 2000U);
  EXPECT_LE(static_cast<std::size_t>(m.mesh.faceCount()), 550U);
  EXPECT_GE(static_cast<std::size_t>(m.mesh.faceCount()), 400U);
  EXPECT_NEAR(m.mesh_volume_ml, m.voxel_volume_ml, m.volume_tolerance_ml);
}

TEST(LabelMeshing, SeveralLabelsGetOneNamedColouredMeshEach) {
  const auto labels = test::paintVolume({40, 20, 20}, Eigen::Vector3d::Ones(), Eigen::Vector3d::Zero(),
                                        Eigen::Matrix3d::Identity(), PixelType::Int16, [](const Eigen::Vector3d& p) {
                                          if ((p - Eigen::Vector3d(10, 10, 10)).norm() < 6) return 20.0;  // L1
                                          if ((p - Eigen::Vector3d(28, 10, 10)).norm() < 5) return 5.0;   // C5
                                          return 0.0;
                                        });
  const auto result = meshLabelMap(labels);
  EXPECT_EQ(result.scheme, LabelScheme::Verse);
  ASSERT_EQ(result.meshes.size(), 2U);
  EXPECT_EQ(result.meshes[0].name, "C5");
  EXPECT_EQ(result.meshes[1].name, "L1");
  EXPECT_EQ(result.meshes[0].mesh.name, "C5");
  EXPECT_NE(result.meshes[0].color, result.meshes[1].color);
  EXPECT_EQ(result.meshes[0].mesh.colors.rows(), result.meshes[0].mesh.vertexCount());
  EXPECT_LT(boundingBox(result.meshes[0].mesh).min().x(), 28 - 4);
  EXPECT_GT(boundingBox(result.meshes[0].mesh).min().x(), 28 - 6);

  LabelMeshOptions only;
  only.labels = {20};
  only.scheme = LabelScheme::TotalSegmentator;
  only.names[20] = "custom";
  const auto single = meshLabelMap(labels, only);
  ASSERT_EQ(single.meshes.size(), 1U);
  EXPECT_EQ(single.meshes[0].name, "custom");
}

TEST(LabelMeshing, LabelTablesFollowVerseAndTotalSegmentator) {
  EXPECT_EQ(labelInfo(1, LabelScheme::Verse).name, "C1");
  EXPECT_EQ(labelInfo(7, LabelScheme::Verse).name, "C7");
  EXPECT_EQ(labelInfo(8, LabelScheme::Verse).name, "T1");
  EXPECT_EQ(labelInfo(19, LabelScheme::Verse).name, "T12");
  EXPECT_EQ(labelInfo(20, LabelScheme::Verse).name, "L1");
  EXPECT_EQ(labelInfo(25, LabelScheme::Verse).name, "L6");
  EXPECT_EQ(labelInfo(28, LabelScheme::Verse).name, "T13");
  EXPECT_TRUE(labelInfo(28, LabelScheme::Verse).vertebra);
  EXPECT_EQ(labelInfo(kPhantomScrewLabel, LabelScheme::Verse).name, "fiducial_screws");
  EXPECT_EQ(labelInfo(31, LabelScheme::TotalSegmentator).name, "vertebrae_L1");
  EXPECT_EQ(labelInfo(26, LabelScheme::TotalSegmentator).name, "vertebrae_S1");
  EXPECT_EQ(labelInfo(50, LabelScheme::TotalSegmentator).name, "vertebrae_C1");
  EXPECT_EQ(labelInfo(117, LabelScheme::TotalSegmentator).name, "costal_cartilages");
  EXPECT_EQ(labelInfo(118, LabelScheme::TotalSegmentator).name, "label_118");
  EXPECT_EQ(totalSegmentatorLabel("vertebrae_L5"), 27);
  EXPECT_EQ(verseLabel("C3"), 3);
  EXPECT_EQ(verseLabel("T13"), 28);
  EXPECT_FALSE(verseLabel("X9").has_value());
  EXPECT_EQ(detectLabelScheme({3, 4, 5, 91, 92}), LabelScheme::Verse);
  EXPECT_EQ(detectLabelScheme({26, 27, 31, 33}), LabelScheme::TotalSegmentator);
  EXPECT_THROW((void)labelSchemeFromName("slicer"), InvalidArgumentError);
}

TEST(LabelMeshing, EmptyOrNonIntegerLabelMapsAreRefusedClearly) {
  const auto zeros =
      test::paintVolume({5, 5, 5}, Eigen::Vector3d::Ones(), Eigen::Vector3d::Zero(), Eigen::Matrix3d::Identity(),
                        PixelType::UInt8, [](const Eigen::Vector3d&) { return 0; });
  try {
    (void)meshLabelMap(zeros);
    FAIL() << "an all-zero label map must be refused";
  } catch (const InvalidArgumentError& e) {
    EXPECT_NE(std::string(e.what()).find("no labelled voxel"), std::string::npos) << e.what();
  }
  const SphereCase s = obliqueSphere(3);
  LabelMeshOptions options;
  options.labels = {4};
  try {
    (void)meshLabelMap(s.labels, options);
    FAIL() << "an empty label must be refused";
  } catch (const InvalidArgumentError& e) {
    EXPECT_NE(std::string(e.what()).find("label 4 is empty"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("labels present: 3"), std::string::npos) << e.what();
  }
  const auto ct =
      test::paintVolume({5, 5, 5}, Eigen::Vector3d::Ones(), Eigen::Vector3d::Zero(), Eigen::Matrix3d::Identity(),
                        PixelType::Float32, [](const Eigen::Vector3d& p) { return 0.5 + p.x(); });
  EXPECT_THROW((void)meshLabelMap(ct), InvalidArgumentError);
  EXPECT_THROW((void)meshLabelMap(ImageVolume{}), InvalidArgumentError);
}

// Real data (a): TotalSegmentator's lumbar labels. The mesh volume must match
// the label's voxel volume within A h / 2 (h = 3 mm). spine_report.json's
// volumes are NOT the whole-label volumes: they are ~0.61 of them for L1-L4
// (and 0.52 for L5): TotalSegmentator reports them for the vertebral body
// (its heights are body heights), so only "smaller than the whole vertebra"
// and the ordering L1 < L2 < L3 < L4 can be checked against the report.
TEST(LabelMeshingRealData, TotalSegmentatorLumbarMeshVolumesMatchTheirVoxels) {
  MRSNS_REQUIRE_DATA(labels_path, "ct/totalsegmentator/spine_report/example_ct_report/totalseg.nii.gz");
  MRSNS_REQUIRE_DATA(report_path, "ct/totalsegmentator/spine_report/example_ct_report/spine_report.json");
  const ImageVolume labels = io::readImage(labels_path);
  std::ifstream in(report_path);
  const auto report = nlohmann::json::parse(in).at("results");
  LabelMeshOptions options;
  for (const char* name : {"vertebrae_L5", "vertebrae_L4", "vertebrae_L3", "vertebrae_L2", "vertebrae_L1"}) {
    options.labels.push_back(*totalSegmentatorLabel(name));
  }
  const auto result = meshLabelMap(labels, options);
  ASSERT_EQ(result.scheme, LabelScheme::TotalSegmentator);
  ASSERT_EQ(result.meshes.size(), 5U);
  std::map<std::string, double> mesh_ml;
  for (const auto& m : result.meshes) {
    SCOPED_TRACE(m.name);
    EXPECT_TRUE(m.closed);
    EXPECT_NEAR(m.mesh_volume_ml, m.voxel_volume_ml, m.volume_tolerance_ml);
    const double reported = report.at(m.name + "_volume_ml").get<double>();
    EXPECT_GT(m.mesh_volume_ml, reported);
    EXPECT_LT(m.mesh_volume_ml, 2.5 * reported);
    mesh_ml[m.name] = m.mesh_volume_ml;
    std::cout << m.name << ": mesh " << m.mesh_volume_ml << " ml, voxels " << m.voxel_volume_ml << " ml (+/- "
              << m.volume_tolerance_ml << "), report " << reported << " ml, ratio " << reported / m.mesh_volume_ml
              << "\n";
  }
  EXPECT_LT(mesh_ml["vertebrae_L1"], mesh_ml["vertebrae_L2"]);
  EXPECT_LT(mesh_ml["vertebrae_L2"], mesh_ml["vertebrae_L3"]);
  EXPECT_LT(mesh_ml["vertebrae_L3"], mesh_ml["vertebrae_L4"]);
}

// Real data (c): VerSe T9-L5. Whole-vertebra centroids lie 10-14 mm
// posterior of the body centroids of the _ctd.json (data README): < 20 mm,
// and the cranio-caudal order must be the same.
TEST(LabelMeshingRealData, VerseMeshCentroidsFollowTheBodyCentroids) {
  MRSNS_REQUIRE_DATA(mask_path, "ct/verse/sub-verse004_seg-vert_msk.nii.gz");
  MRSNS_REQUIRE_DATA(ctd_path, "ct/verse/sub-verse004_seg-subreg_ctd.json");
  const ImageVolume labels = io::readImage(mask_path);
  std::ifstream in(ctd_path);
  const auto ctd = nlohmann::json::parse(in);
  // The centroids are continuous voxel indices of this (PIR-ordered) image.
  std::map<int, Eigen::Vector3d> body;
  for (const auto& entry : ctd) {
    if (!entry.contains("label")) continue;
    body[entry.at("label").get<int>()] = labels.indexToPhysical(
        Eigen::Vector3d(entry.at("X").get<double>(), entry.at("Y").get<double>(), entry.at("Z").get<double>()));
  }
  ASSERT_EQ(body.size(), 9U);
  LabelMeshOptions options;
  options.target_triangles = 4000;
  const auto result = meshLabelMap(labels, options);
  ASSERT_EQ(result.meshes.size(), 9U);
  const Eigen::Vector3d axis = (body.at(24) - body.at(16)).normalized();
  EXPECT_GT(axis.dot(-Eigen::Vector3d::UnitZ()), 0.9) << "T9 -> L5 runs inferior in LPS";
  std::vector<std::pair<double, int>> along;
  for (const auto& m : result.meshes) {
    SCOPED_TRACE(m.name);
    EXPECT_EQ(m.name, labelInfo(m.label, LabelScheme::Verse).name);
    const Eigen::Vector3d c = volumeCentroid(m.mesh);
    const double d = (c - body.at(m.label)).norm();
    EXPECT_LT(d, 20.0);
    std::cout << m.name << ": mesh centroid " << d << " mm from the body centroid, " << m.mesh.faceCount()
              << " triangles\n";
    along.emplace_back(c.dot(axis), m.label);
  }
  std::sort(along.begin(), along.end());
  for (std::size_t i = 0; i < along.size(); ++i) EXPECT_EQ(along[i].second, 16 + static_cast<int>(i));
}

}  // namespace
}  // namespace mrsns::registration
