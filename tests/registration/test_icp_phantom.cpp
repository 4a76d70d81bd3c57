// Surface registration, fiducial detection and screw-path clearance on the
// bundled cervical phantom's CT meshes (label maps meshed as in the
// workflow), against the phantom's known geometry.
#include <gtest/gtest.h>

#include <random>

#include "mrsns/core/mesh_locator.h"
#include "mrsns/registration/fiducials_from_mesh.h"
#include "mrsns/registration/label_meshing.h"
#include "mrsns/registration/phantom_cervical.h"
#include "mrsns/registration/screw_path.h"
#include "mrsns/registration/surface_registration.h"
#include "surface_fixtures.h"

namespace mrsns::registration {
namespace {

using test::kDegree;

struct PhantomMeshes {
  CervicalPhantom phantom = generateCervicalPhantom();
  TriangleMesh bone;    // all vertebrae, without screw holes
  TriangleMesh c5;      // one vertebra
  TriangleMesh screws;  // titanium
  TriangleMesh vessel;
  PhantomMeshes() {
    LabelMeshOptions o;
    o.scheme = LabelScheme::Generic;
    const auto bones = meshLabelMap(phantom.bone_labels, o);
    std::vector<TriangleMesh> parts;
    for (const auto& m : bones.meshes) {
      parts.push_back(m.mesh);
      if (m.label == 5) c5 = m.mesh;
    }
    bone = mergeMeshes(parts);
    o.labels = {92};
    screws = meshLabelMap(phantom.labels, o).meshes.at(0).mesh;
    o.labels = {91};
    vessel = meshLabelMap(phantom.labels, o).meshes.at(0).mesh;
  }
};

const PhantomMeshes& meshes() {
  static const PhantomMeshes m;
  return m;
}

TEST(PhantomSurfaces, FiducialScrewsAreFoundWithinHalfAMillimetreOfTheirBoneEntry) {
  const auto& m = meshes();
  const auto& truth = m.phantom.fiducials_truth;
  ASSERT_EQ(truth.size(), 8u);
  const auto result = findFiducialsFromMeshes(m.screws, m.bone, static_cast<int>(truth.size()));
  std::vector<int> used(truth.size(), 0);
  for (const auto& f : result.fiducials) {
    std::size_t best = 0;
    for (std::size_t k = 1; k < truth.size(); ++k) {
      if ((f.position - truth.points[k].position).norm() < (f.position - truth.points[best].position).norm()) best = k;
    }
    ++used[best];
    const double error = (f.position - truth.points[best].position).norm();
    EXPECT_LT(error, 0.5) << f.label << " vs " << truth.points[best].label;
    RecordProperty(f.label + "_error_mm", std::to_string(error));
    EXPECT_TRUE(f.axis_hits_bone) << f.label;
  }
  for (std::size_t k = 0; k < used.size(); ++k) EXPECT_EQ(used[k], 1) << truth.points[k].label;
}

TEST(PhantomSurfaces, IcpOnTheC5SurfaceConvergesFrom20mmAnd20DegreeStarts) {
  // Points digitised on C5 with 0.2 mm per-axis noise (as a tracked pointer
  // would), registered onto the C5 CT mesh from 10 random starts.
  const auto& m = meshes();
  ASSERT_FALSE(m.c5.empty());
  const IcpSurface surface(m.c5);
  const auto fixed_points = test::sampleSurface(m.c5, 1000, 0.2, 77);
  Eigen::Vector3d c = Eigen::Vector3d::Zero();
  for (const auto& p : fixed_points) c += p;
  c /= static_cast<double>(fixed_points.size());
  std::mt19937_64 rng(21);
  const auto truth = test::randomPerturbation(rng, 30 * kDegree, 50.0, c);
  const auto moving = test::transformPoints(truth.inverse(), fixed_points);
  const Eigen::Vector3d at = truth.inverse() * c;
  int converged = 0;
  for (int k = 0; k < 10; ++k) {
    const auto start = test::randomPerturbation(rng, 20 * kDegree, 20.0, c) * truth;
    const auto r = registerSurface(moving, surface, start);
    const auto e = test::poseError(r.fixed_T_moving, truth, at);
    SCOPED_TRACE("start " + std::to_string(k));
    // Noise-limited: ~sigma / sqrt(N) / extent; tolerances leave a factor >= 5.
    EXPECT_LT(e.rotation, 0.25 * kDegree);
    EXPECT_LT(e.translation, 0.1);
    EXPECT_NEAR(r.rms_mm, 0.2, 0.03);
    converged += r.converged ? 1 : 0;
  }
  EXPECT_EQ(converged, 10);
}

TEST(PhantomSurfaces, PlannedPedicleScrewsKeepClearOfTheVessel) {
  const auto& m = meshes();
  ASSERT_FALSE(m.phantom.screw_paths.empty());
  const MeshLocator vessel(m.vessel);
  for (const auto& path : m.phantom.screw_paths) {
    const auto c = screwPathClearance(path, vessel);
    EXPECT_FALSE(c.cuts_surface) << path.name;
    EXPECT_GT(c.min_clearance_mm, 0.0) << path.name;
    RecordProperty(path.name + "_vessel_clearance_mm", std::to_string(c.min_clearance_mm));
  }
}

}  // namespace
}  // namespace mrsns::registration
