// The bundled cervical phantom: reproducibility, anatomy at its known
// places, fiducial ground truth, planned pedicle screw paths, noise, and bone
// segmentation recovering its vertebrae.
#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <iostream>
#include <map>
#include <numbers>

#include "mrsns/core/error.h"
#include "mrsns/registration/ct_bone_segmentation.h"
#include "mrsns/registration/label_meshing.h"
#include "mrsns/registration/label_names.h"
#include "mrsns/registration/phantom_cervical.h"

namespace mrsns::registration {
namespace {

/// One phantom at the default 0.8 mm, built once for the suite (~1 s).
const CervicalPhantom& defaultPhantom() {
  static const CervicalPhantom phantom = generateCervicalPhantom();
  return phantom;
}

double valueAt(const ImageVolume& image, const Eigen::Vector3d& p_lps) {
  const Eigen::Vector3d ijk = image.physicalToIndex(p_lps);
  const int i = static_cast<int>(std::lround(ijk.x()));
  const int j = static_cast<int>(std::lround(ijk.y()));
  const int k = static_cast<int>(std::lround(ijk.z()));
  if (!image.contains(i, j, k)) ADD_FAILURE() << "point outside the phantom: " << p_lps.transpose();
  return image.contains(i, j, k) ? image.value(i, j, k) : -1.0;
}

TEST(Phantom, IsFastAndDeterministicForASeed) {
  PhantomOptions options;
  options.spacing_mm = 1.0;
  const auto start = std::chrono::steady_clock::now();
  const auto a = generateCervicalPhantom(options);
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  std::cout << "phantom at 1.0 mm: " << a.ct.size[0] << "x" << a.ct.size[1] << "x" << a.ct.size[2] << " in " << seconds
            << " s\n";
  EXPECT_LT(seconds, 5.0);
  const auto b = generateCervicalPhantom(options);
  EXPECT_EQ(a.ct.data, b.ct.data);
  EXPECT_EQ(a.labels.data, b.labels.data);
  options.seed = 2;
  const auto c = generateCervicalPhantom(options);
  EXPECT_NE(a.ct.data, c.ct.data) << "another seed draws other noise";
  EXPECT_EQ(a.labels.data, c.labels.data) << "the anatomy does not depend on the seed";
  for (std::size_t i = 0; i < a.screws.size(); ++i) EXPECT_EQ(a.screws[i].bone_entry, c.screws[i].bone_entry);
}

TEST(Phantom, GeometryAndTypesAreCtLike) {
  const auto& p = defaultPhantom();
  EXPECT_EQ(p.ct.pixel_type, PixelType::Int16);
  EXPECT_EQ(p.labels.pixel_type, PixelType::UInt8);
  EXPECT_EQ(p.ct.size, (std::array<int, 3>{150, 150, 175}));
  EXPECT_EQ(p.labels.size, p.ct.size);
  EXPECT_NEAR(p.ct.physicalExtent().x(), 120.0, 1e-9);
  EXPECT_NEAR(p.ct.physicalExtent().z(), 140.0, 1e-9);
  EXPECT_EQ(p.ct.frame, "CT");
  ASSERT_EQ(p.vertebrae.size(), 5U);
  EXPECT_EQ(p.vertebrae.front().name, "C3");
  EXPECT_EQ(p.vertebrae.back().name, "C7");
  EXPECT_EQ(p.label_names.at(kPhantomVesselLabel), "carotid_artery");
}

TEST(Phantom, StructuresAreAtTheirKnownPlaces) {
  const auto& p = defaultPhantom();
  using D = PhantomDensities;
  const double noise = 5.0 * p.noise_sigma_hu;
  for (const auto& v : p.vertebrae) {
    SCOPED_TRACE(v.name);
    EXPECT_EQ(valueAt(p.labels, v.body_center), v.label);
    EXPECT_NEAR(valueAt(p.ct, v.body_center), D::cancellous_bone, noise);
    // The spinal canal, ~14 mm behind the body centre, is soft tissue.
    const Eigen::Vector3d canal = v.body_center + v.rotation * Eigen::Vector3d(0.0, 14.0, 0.0);
    EXPECT_EQ(valueAt(p.labels, canal), 0.0);
    EXPECT_NEAR(valueAt(p.ct, canal), D::soft_tissue, noise);
    // Vertebrae stack superior to inferior, 19 mm apart.
  }
  for (std::size_t i = 1; i < p.vertebrae.size(); ++i) {
    EXPECT_NEAR((p.vertebrae[i - 1].body_center - p.vertebrae[i].body_center).norm(), 19.0, 0.5);
    EXPECT_GT(p.vertebrae[i - 1].body_center.z(), p.vertebrae[i].body_center.z());
  }
  // Vessel: contrast lumen on its centre line, left (+x) and anterior (-y) of the spine.
  for (double z : {-50.0, 0.0, 50.0}) {
    const Eigen::Vector3d c(p.vessel_center.x(), p.vessel_center.y(), z);
    EXPECT_EQ(valueAt(p.labels, c), kPhantomVesselLabel);
    EXPECT_NEAR(valueAt(p.ct, c), D::vessel_lumen, noise);
  }
  EXPECT_GT(p.vessel_center.x(), 0.0);
  EXPECT_LT(p.vessel_center.y(), p.vertebrae[2].body_center.y());
  // Screws: titanium along the shaft, half in bone.
  ASSERT_EQ(p.screws.size(), 8U);
  for (const auto& s : p.screws) {
    SCOPED_TRACE(s.label);
    const Eigen::Vector3d mid_shaft = 0.5 * (s.tip + s.bone_entry);
    EXPECT_EQ(valueAt(p.labels, mid_shaft), kPhantomScrewLabel);
    EXPECT_NEAR(valueAt(p.ct, mid_shaft), D::titanium, noise);
    EXPECT_LT(phantomBoneDistance(p, mid_shaft), 0.0) << "the shaft's inner half is in bone";
    EXPECT_GT(phantomBoneDistance(p, s.head), 0.0) << "the head stands out of the bone";
    EXPECT_NEAR((s.head - s.tip).norm(), s.length_mm, 1e-9);
  }
  // Air outside the neck, at a corner, and in the trachea.
  EXPECT_LT(valueAt(p.ct, Eigen::Vector3d(58, 58, 0)), -900.0);
  EXPECT_LT(valueAt(p.ct, Eigen::Vector3d(0, -30, 0)), -900.0);
}

TEST(Phantom, FiducialTruthIsWhereEachScrewAxisLeavesTheBone) {
  const auto& p = defaultPhantom();
  ASSERT_EQ(p.fiducials_truth.size(), 8U);
  EXPECT_EQ(p.fiducials_truth.frame, "CT");
  double spread = 0.0;
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (const auto& l : p.fiducials_truth.points) mean += l.position / 8.0;
  for (std::size_t i = 0; i < p.screws.size(); ++i) {
    const auto& s = p.screws[i];
    SCOPED_TRACE(s.label);
    EXPECT_EQ(p.fiducials_truth.points[i].label, s.label);
    EXPECT_EQ(p.fiducials_truth.points[i].position, s.bone_entry);
    EXPECT_NEAR(phantomBoneDistance(p, s.bone_entry), 0.0, 1e-6);
    EXPECT_LT(phantomBoneDistance(p, s.bone_entry - 0.2 * s.axis), 0.0);
    EXPECT_GT(phantomBoneDistance(p, s.bone_entry + 0.2 * s.axis), 0.0);
    EXPECT_NEAR(s.axis.norm(), 1.0, 1e-12);
    EXPECT_GT(s.axis.y(), 0.5) << "screws point posteriorly, out of the back of the spine";
    spread += (p.fiducials_truth.points[i].position - mean).squaredNorm() / 8.0;
  }
  EXPECT_GT(std::sqrt(spread), 20.0) << "fiducials spread over the cervical spine";
}

TEST(Phantom, PedicleScrewPathsRunThroughThePediclesIntoTheBody) {
  const auto& p = defaultPhantom();
  ASSERT_EQ(p.screw_paths.size(), 4U);
  for (const auto& path : p.screw_paths) {
    SCOPED_TRACE(path.name);
    const auto& v = p.vertebrae[path.vertebra == "C5" ? 2 : 3];
    EXPECT_TRUE(path.vertebra == "C5" || path.vertebra == "C6");
    // Cervical pedicle screws are 20-30 mm long.
    EXPECT_GT(path.effectiveLength(), 20.0);
    EXPECT_LT(path.effectiveLength(), 30.0);
    const Eigen::Vector3d entry_local = v.rotation.transpose() * (path.entry - v.body_center);
    const Eigen::Vector3d target_local = v.rotation.transpose() * (path.target - v.body_center);
    EXPECT_GT(entry_local.y(), 14.0) << "entry on the posterior lateral mass";
    EXPECT_EQ(entry_local.x() > 0.0, path.name.find("left") != std::string::npos);
    EXPECT_LT(std::abs(target_local.y()), 8.0) << "target in the body";
    EXPECT_NEAR(std::abs(target_local.x()), 3.0, 1e-6) << "left and right tips stay apart";
    // Medial convergence ~45 deg (Karaikovic et al. 1997: 39-49 deg at C3-C7).
    const Eigen::Vector3d d = (target_local - entry_local).normalized();
    EXPECT_NEAR(std::atan2(std::abs(d.x()), -d.y()) * 180.0 / std::numbers::pi, 45.0, 6.0);
    // Every point of the path is bone of this vertebra (the labels, not just the primitives).
    for (double t = 0.02; t < 1.0; t += 0.02) {
      const Eigen::Vector3d q = path.entry + t * (path.target - path.entry);
      ASSERT_EQ(valueAt(p.labels, q), v.label) << "t = " << t;
    }
  }
}

TEST(Phantom, NoiseHasTheRequestedSigma) {
  const auto& p = defaultPhantom();
  // Soft tissue block in front of the vertebrae, away from every edge.
  std::vector<double> values;
  for (double x = -10; x <= 10; x += 0.8) {
    for (double y = -45; y <= -40; y += 0.8) {
      for (double z = -40; z <= 40; z += 0.8) values.push_back(valueAt(p.ct, Eigen::Vector3d(x, y, z)));
    }
  }
  double mean = 0.0;
  for (double v : values) mean += v / static_cast<double>(values.size());
  double var = 0.0;
  for (double v : values) var += (v - mean) * (v - mean) / static_cast<double>(values.size() - 1);
  const double n = static_cast<double>(values.size());
  // Standard errors: sigma / sqrt(n) for the mean, sigma / sqrt(2n) for the SD; 5 of them.
  EXPECT_NEAR(mean, PhantomDensities::soft_tissue, 5.0 * p.noise_sigma_hu / std::sqrt(n) + 0.5);
  EXPECT_NEAR(std::sqrt(var), p.noise_sigma_hu, 5.0 * p.noise_sigma_hu / std::sqrt(2.0 * n) + 0.3);
}

TEST(Phantom, BoneSegmentationRecoversTheVertebrae) {
  const auto& p = defaultPhantom();
  const auto bone = segmentBone(p.ct);
  std::size_t both = 0, in_bone = 0, in_truth = 0, vessel_as_bone = 0;
  std::map<int, std::pair<std::size_t, std::size_t>> per_vertebra;  // found, total
  for (std::size_t i = 0; i < p.labels.voxelCount(); ++i) {
    const int l = static_cast<int>(p.labels.valueAtIndex(i));
    const bool truth = (l >= 3 && l <= 7) || l == kPhantomScrewLabel;
    const bool b = bone.labels.valueAtIndex(i) != 0.0;
    in_truth += truth;
    in_bone += b;
    both += truth && b;
    vessel_as_bone += (l == kPhantomVesselLabel && b) ? 1 : 0;
    if (l >= 3 && l <= 7) {
      per_vertebra[l].first += b ? 1 : 0;
      per_vertebra[l].second += 1;
    }
  }
  const double dice = 2.0 * static_cast<double>(both) / static_cast<double>(in_bone + in_truth);
  std::cout << "phantom bone Dice " << dice << ", " << bone.components.size() << " components\n";
  EXPECT_GT(dice, 0.9);
  // The 150 HU lumen (+5 sigma noise = 225 HU) stays below the 250 HU threshold.
  EXPECT_EQ(vessel_as_bone, 0U);
  ASSERT_EQ(per_vertebra.size(), 5U);
  for (const auto& [label, counts] : per_vertebra) {
    EXPECT_GT(static_cast<double>(counts.first) / static_cast<double>(counts.second), 0.9) << "C" << label;
  }
}

// The vertebra meshes (what fiducial finding and ICP see) lie on the analytic
// bone surface: voxelisation puts the boundary within h / 2 of it along an
// axis (h sqrt(3) / 2 at a corner) and smoothing moves it towards the true
// surface; bound the largest vertex distance by h and the RMS by h / 4.
TEST(Phantom, VertebraMeshesLieOnTheAnalyticBoneSurface) {
  const auto& p = defaultPhantom();
  LabelMeshOptions options;
  options.labels = {5, 6};
  const auto meshes = meshLabelMap(p.bone_labels, options);
  ASSERT_EQ(meshes.meshes.size(), 2U);
  const double h = p.ct.spacing.x();
  for (const auto& m : meshes.meshes) {
    SCOPED_TRACE(m.name);
    EXPECT_TRUE(m.closed);
    double sum2 = 0.0, worst = 0.0;
    for (Eigen::Index v = 0; v < m.mesh.vertexCount(); ++v) {
      const double d = std::abs(phantomBoneDistance(p, m.mesh.vertices.row(v).transpose()));
      sum2 += d * d;
      worst = std::max(worst, d);
    }
    const double rms = std::sqrt(sum2 / static_cast<double>(m.mesh.vertexCount()));
    std::cout << m.name << ": mesh to analytic surface RMS " << rms << " mm, max " << worst << " mm\n";
    EXPECT_LT(rms, h / 4.0);
    EXPECT_LT(worst, h);
  }
}

TEST(Phantom, InvalidOptionsAreRefused) {
  PhantomOptions options;
  options.spacing_mm = 0.0;
  EXPECT_THROW((void)generateCervicalPhantom(options), InvalidArgumentError);
  options = {};
  options.noise_sigma_hu = -1.0;
  EXPECT_THROW((void)generateCervicalPhantom(options), InvalidArgumentError);
  options = {};
  options.extent_mm = Eigen::Vector3d(50, 50, 50);
  EXPECT_THROW((void)generateCervicalPhantom(options), InvalidArgumentError);
}

}  // namespace
}  // namespace mrsns::registration
