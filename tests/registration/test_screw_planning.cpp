// Screw planning figures: the vertebra's anatomical frame, the screw's angles,
// cortical breach and the planning panel's figures. Three kinds of evidence:
// synthetic ground truth (boxes, ellipsoids and spheres with closed-form
// answers), properties of the math (rigid motion, mirror symmetry,
// tessellation, reversal) and real vertebra label maps (TotalSegmentator,
// VerSe) plus the generated cervical phantom with its known geometry.
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <iostream>
#include <map>
#include <numeric>
#include <random>

#include "mrsns/core/error.h"
#include "mrsns/core/format.h"
#include "mrsns/core/mesh_locator.h"
#include "mrsns/core/mesh_ops.h"
#include "mrsns/io/image_io.h"
#include "mrsns/registration/label_meshing.h"
#include "mrsns/registration/phantom_cervical.h"
#include "mrsns/registration/screw_planning.h"
#include "surface_fixtures.h"
#include "test_data.h"

namespace mrsns::registration {
// A named namespace: the test program is a unity build, so these helpers
// must not meet another test file's anonymous-namespace helpers.
namespace screw_planning_test {

constexpr double kDegPlan = 3.14159265358979323846 / 180.0;

/// A closed box mesh on a grid whose lines along each axis sit at the given
/// fractions (0..1, sorted, first 0 and last 1) of the box: uneven fractions
/// make the vertices dense on one side without changing the solid.
TriangleMesh planGridBox(const Eigen::Vector3d& lo, const Eigen::Vector3d& hi,
                         const std::array<std::vector<double>, 3>& fractions) {
  const std::array<int, 3> n{static_cast<int>(fractions[0].size()), static_cast<int>(fractions[1].size()),
                             static_cast<int>(fractions[2].size())};
  std::map<std::array<int, 3>, int> index;
  std::vector<Eigen::Vector3d> vertices;
  const auto vertex = [&](std::array<int, 3> ijk) {
    const auto it = index.find(ijk);
    if (it != index.end()) return it->second;
    Eigen::Vector3d p;
    for (int a = 0; a < 3; ++a) {
      p(a) = lo(a) + (hi(a) - lo(a)) * fractions[static_cast<std::size_t>(a)][static_cast<std::size_t>(ijk[a])];
    }
    vertices.push_back(p);
    index[ijk] = static_cast<int>(vertices.size()) - 1;
    return index[ijk];
  };
  std::vector<Eigen::Vector3i> faces;
  for (int a = 0; a < 3; ++a) {
    const int b = (a + 1) % 3;
    const int c = (a + 2) % 3;
    for (const int side : {0, n[static_cast<std::size_t>(a)] - 1}) {
      const Eigen::Vector3d outward = Eigen::Vector3d::Unit(a) * (side == 0 ? -1.0 : 1.0);
      for (int i = 0; i + 1 < n[static_cast<std::size_t>(b)]; ++i) {
        for (int j = 0; j + 1 < n[static_cast<std::size_t>(c)]; ++j) {
          std::array<int, 4> q{};
          const int corners[4][2] = {{i, j}, {i + 1, j}, {i + 1, j + 1}, {i, j + 1}};
          for (int k = 0; k < 4; ++k) {
            std::array<int, 3> ijk{};
            ijk[static_cast<std::size_t>(a)] = side;
            ijk[static_cast<std::size_t>(b)] = corners[k][0];
            ijk[static_cast<std::size_t>(c)] = corners[k][1];
            q[static_cast<std::size_t>(k)] = vertex(ijk);
          }
          // Orient on the unit grid (never degenerate, even for a flat box).
          const auto unit = [&](int k) {
            Eigen::Vector3d t = Eigen::Vector3d::Zero();
            t(a) = side == 0 ? 0.0 : 1.0;
            t(b) = corners[k][0];
            t(c) = corners[k][1];
            return t;
          };
          const Eigen::Vector3d normal = (unit(1) - unit(0)).cross(unit(2) - unit(0));
          if (normal.dot(outward) > 0.0) {
            faces.emplace_back(q[0], q[1], q[2]);
            faces.emplace_back(q[0], q[2], q[3]);
          } else {
            faces.emplace_back(q[0], q[2], q[1]);
            faces.emplace_back(q[0], q[3], q[2]);
          }
        }
      }
    }
  }
  TriangleMesh mesh;
  mesh.name = "box";
  mesh.vertices.resize(static_cast<Eigen::Index>(vertices.size()), 3);
  for (std::size_t v = 0; v < vertices.size(); ++v) mesh.vertices.row(static_cast<Eigen::Index>(v)) = vertices[v];
  mesh.faces.resize(static_cast<Eigen::Index>(faces.size()), 3);
  for (std::size_t f = 0; f < faces.size(); ++f) mesh.faces.row(static_cast<Eigen::Index>(f)) = faces[f].transpose();
  return mesh;
}

std::vector<double> planUniform(int cells) {
  std::vector<double> t;
  for (int i = 0; i <= cells; ++i) t.push_back(static_cast<double>(i) / cells);
  return t;
}

/// The box [-20, 20] x [-15, 15] x [-10, 10] mm (left-right 40, antero-posterior
/// 30, cranio-caudal 20, like a vertebra's proportions) shifted by `centre`.
TriangleMesh planVertebraBox(const Eigen::Vector3d& centre = Eigen::Vector3d::Zero()) {
  return planGridBox(centre + Eigen::Vector3d(-20, -15, -10), centre + Eigen::Vector3d(20, 15, 10),
                     {planUniform(8), planUniform(6), planUniform(4)});
}

/// A UV ellipsoid (poles on z, `segments` even): mirror-symmetric about the
/// three coordinate planes, so its principal axes are exactly x, y, z.
TriangleMesh planEllipsoid(const Eigen::Vector3d& semi_axes, int rings, int segments) {
  TriangleMesh mesh;
  mesh.name = "ellipsoid";
  const int n = 2 + (rings - 1) * segments;
  mesh.vertices.resize(n, 3);
  mesh.vertices.row(0) << 0.0, 0.0, semi_axes.z();
  for (int i = 1; i < rings; ++i) {
    const double theta = test::kPi * i / rings;
    for (int j = 0; j < segments; ++j) {
      const double phi = 2.0 * test::kPi * j / segments;
      mesh.vertices.row(1 + (i - 1) * segments + j) << semi_axes.x() * std::sin(theta) * std::cos(phi),
          semi_axes.y() * std::sin(theta) * std::sin(phi), semi_axes.z() * std::cos(theta);
    }
  }
  mesh.vertices.row(n - 1) << 0.0, 0.0, -semi_axes.z();
  const auto v = [&](int i, int j) { return 1 + (i - 1) * segments + (j % segments); };
  std::vector<Eigen::Vector3i> faces;
  for (int j = 0; j < segments; ++j) faces.emplace_back(0, v(1, j), v(1, j + 1));
  for (int i = 1; i < rings - 1; ++i) {
    for (int j = 0; j < segments; ++j) {
      faces.emplace_back(v(i, j), v(i + 1, j), v(i + 1, j + 1));
      faces.emplace_back(v(i, j), v(i + 1, j + 1), v(i, j + 1));
    }
  }
  for (int j = 0; j < segments; ++j) faces.emplace_back(n - 1, v(rings - 1, j + 1), v(rings - 1, j));
  mesh.faces.resize(static_cast<Eigen::Index>(faces.size()), 3);
  for (std::size_t f = 0; f < faces.size(); ++f) mesh.faces.row(static_cast<Eigen::Index>(f)) = faces[f].transpose();
  if (signedVolume(mesh) < 0.0) mesh.faces.col(1).swap(mesh.faces.col(2));
  return mesh;
}

/// Each triangle split into four at its edges' midpoints: the same surface, more vertices.
TriangleMesh planSubdivide(const TriangleMesh& mesh) {
  std::map<std::pair<int, int>, int> midpoint;
  std::vector<Eigen::Vector3d> vertices;
  for (Eigen::Index v = 0; v < mesh.vertexCount(); ++v) vertices.push_back(mesh.vertices.row(v).transpose());
  const auto mid = [&](int a, int b) {
    const auto key = std::minmax(a, b);
    const auto it = midpoint.find(key);
    if (it != midpoint.end()) return it->second;
    vertices.push_back(0.5 * (vertices[static_cast<std::size_t>(a)] + vertices[static_cast<std::size_t>(b)]));
    return midpoint[key] = static_cast<int>(vertices.size()) - 1;
  };
  std::vector<Eigen::Vector3i> faces;
  for (Eigen::Index f = 0; f < mesh.faceCount(); ++f) {
    const int a = mesh.faces(f, 0), b = mesh.faces(f, 1), c = mesh.faces(f, 2);
    const int ab = mid(a, b), bc = mid(b, c), ca = mid(c, a);
    faces.emplace_back(a, ab, ca);
    faces.emplace_back(ab, b, bc);
    faces.emplace_back(ca, bc, c);
    faces.emplace_back(ab, bc, ca);
  }
  TriangleMesh out;
  out.name = mesh.name;
  out.vertices.resize(static_cast<Eigen::Index>(vertices.size()), 3);
  for (std::size_t v = 0; v < vertices.size(); ++v) out.vertices.row(static_cast<Eigen::Index>(v)) = vertices[v];
  out.faces.resize(static_cast<Eigen::Index>(faces.size()), 3);
  for (std::size_t f = 0; f < faces.size(); ++f) out.faces.row(static_cast<Eigen::Index>(f)) = faces[f].transpose();
  return out;
}

/// The same surface with its faces and vertices shuffled and each face's
/// corners turned cyclically (winding kept).
TriangleMesh planShuffle(const TriangleMesh& mesh, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::vector<int> vertex_order(static_cast<std::size_t>(mesh.vertexCount()));
  std::iota(vertex_order.begin(), vertex_order.end(), 0);
  std::shuffle(vertex_order.begin(), vertex_order.end(), rng);
  std::vector<int> new_index(vertex_order.size());
  TriangleMesh out;
  out.name = mesh.name;
  out.vertices.resize(mesh.vertexCount(), 3);
  for (std::size_t i = 0; i < vertex_order.size(); ++i) {
    out.vertices.row(static_cast<Eigen::Index>(i)) = mesh.vertices.row(vertex_order[i]);
    new_index[static_cast<std::size_t>(vertex_order[i])] = static_cast<int>(i);
  }
  std::vector<Eigen::Index> face_order(static_cast<std::size_t>(mesh.faceCount()));
  std::iota(face_order.begin(), face_order.end(), Eigen::Index{0});
  std::shuffle(face_order.begin(), face_order.end(), rng);
  out.faces.resize(mesh.faceCount(), 3);
  for (std::size_t i = 0; i < face_order.size(); ++i) {
    const int turn = static_cast<int>(i % 3);
    for (int k = 0; k < 3; ++k) {
      out.faces(static_cast<Eigen::Index>(i), k) =
          new_index[static_cast<std::size_t>(mesh.faces(face_order[i], (k + turn) % 3))];
    }
  }
  return out;
}

/// The mesh mirrored through x = 0 (left <-> right), faces re-wound outwards.
TriangleMesh planMirror(const TriangleMesh& mesh) {
  TriangleMesh out = mesh;
  out.vertices.col(0) = -out.vertices.col(0);
  out.faces.col(1).swap(out.faces.col(2));
  return out;
}

ScrewPath planScrew(const Eigen::Vector3d& entry, const Eigen::Vector3d& direction, double length,
                    double diameter = 3.5, const std::string& vertebra = "L2") {
  ScrewPath p;
  p.name = "test screw";
  p.vertebra = vertebra;
  p.entry = entry;
  p.target = entry + 10.0 * direction.normalized();
  p.diameter_mm = diameter;
  p.length_mm = length;
  return p;
}

Eigen::Vector3d planDirection(double medial_deg, double cranial_deg, bool right_side) {
  // Right side: medial is towards +x (left). Anterior is -y.
  const double m = medial_deg * kDegPlan;
  const double c = cranial_deg * kDegPlan;
  return Eigen::Vector3d((right_side ? 1.0 : -1.0) * std::sin(m) * std::cos(c), -std::cos(m) * std::cos(c),
                         std::sin(c));
}

double planAngleBetween(const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  return std::atan2(a.cross(b).norm(), a.dot(b));
}

// ===========================================================================
// (a) Synthetic ground truth: the frame

TEST(ScrewPlanningFrame, BoxFrameIsTheSolidsCentreAndAxesNotTheVertexMean) {
  const Eigen::Vector3d centre(5.0, -3.0, 100.0);
  // Grid lines crowd towards +x: many more vertices on the left half.
  std::vector<double> crowded;
  for (int i = 0; i <= 12; ++i) crowded.push_back(std::sqrt(i / 12.0));
  const TriangleMesh box = planGridBox(centre + Eigen::Vector3d(-20, -15, -10), centre + Eigen::Vector3d(20, 15, 10),
                                       {crowded, planUniform(6), planUniform(4)});
  ASSERT_TRUE(isClosed(box));
  EXPECT_GT((vertexCentroid(box) - centre).norm(), 1.0) << "the vertex mean must be biased for this test to mean much";
  const VertebraFrame f = vertebraFrame(box);
  EXPECT_LT((f.origin - centre).norm(), 1e-9);
  EXPECT_NEAR(f.volume_mm3, 40.0 * 30.0 * 20.0, 1e-6);
  EXPECT_LT((f.left - Eigen::Vector3d::UnitX()).norm(), 1e-9);
  EXPECT_LT((f.posterior - Eigen::Vector3d::UnitY()).norm(), 1e-9);
  EXPECT_LT((f.superior - Eigen::Vector3d::UnitZ()).norm(), 1e-9);
  EXPECT_LT((f.extent_mm - Eigen::Vector3d(40, 30, 20)).norm(), 1e-9);
  EXPECT_LT((f.extent_min_mm - Eigen::Vector3d(-20, -15, -10)).norm(), 1e-9);
  // A uniform solid on [-a, a] has second moment a^2 / 3.
  EXPECT_LT((f.principal_rms_mm - Eigen::Vector3d(20, 15, 10) / std::sqrt(3.0)).norm(), 1e-9);
  EXPECT_NEAR(f.alignment, 1.0, 1e-12);
  EXPECT_NEAR(f.confidence, 1.0, 1e-12);
  // Moments 400/3, 225/3, 100/3: smallest gap 125/3 over 400/3.
  EXPECT_NEAR(f.moment_separation, 125.0 / 400.0, 1e-9);
  EXPECT_FALSE(f.ambiguous);
  EXPECT_FALSE(f.superior_from_hint);
  EXPECT_TRUE(f.warnings.empty());
  EXPECT_TRUE(f.lps_T_vertebra().isApprox(Eigen::Isometry3d(Eigen::Translation3d(centre)), 1e-12));
}

TEST(ScrewPlanningFrame, RotatedEllipsoidAxesFollowThePoseAndConfidenceIsCosMinusSin) {
  // A 20 deg lordosis-like tilt about the left axis: the frame follows the
  // solid, and the closest competing assignment (posterior <-> superior)
  // scores 2 sin t + 1 against 2 cos t + 1: confidence cos t - sin t.
  const TriangleMesh ellipsoid = planEllipsoid({26.0, 20.0, 13.0}, 48, 96);
  for (const double tilt_deg : {0.0, 20.0, -30.0}) {
    SCOPED_TRACE(tilt_deg);
    const double t = tilt_deg * kDegPlan;
    Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
    pose.linear() = Eigen::AngleAxisd(t, Eigen::Vector3d::UnitX()).toRotationMatrix();
    pose.translation() = Eigen::Vector3d(-40.0, 12.0, 250.0);
    const VertebraFrame f = vertebraFrame(transformMesh(ellipsoid, pose));
    EXPECT_LT((f.origin - pose.translation()).norm(), 1e-9);
    EXPECT_LT(planAngleBetween(f.left, pose.linear().col(0)), 1e-9);
    EXPECT_LT(planAngleBetween(f.posterior, pose.linear().col(1)), 1e-9);
    EXPECT_LT(planAngleBetween(f.superior, pose.linear().col(2)), 1e-9);
    EXPECT_NEAR(f.confidence, std::cos(std::abs(t)) - std::sin(std::abs(t)), 1e-9);
    EXPECT_EQ(f.ambiguous, f.confidence < 0.2);
    // The extents are the semi-axes: the mesh's vertices lie on the ellipsoid.
    EXPECT_LT((f.extent_mm - Eigen::Vector3d(52.0, 40.0, 26.0)).cwiseAbs().maxCoeff(), 1e-6);
  }
  // A compound turn below the assignment's limit.
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  pose.linear() = so3Exp(Eigen::Vector3d(0.25, -0.15, 0.2));  // 20 deg
  const VertebraFrame f = vertebraFrame(transformMesh(ellipsoid, pose));
  EXPECT_LT(planAngleBetween(f.left, pose.linear().col(0)), 1e-9);
  EXPECT_LT(planAngleBetween(f.posterior, pose.linear().col(1)), 1e-9);
  EXPECT_LT(planAngleBetween(f.superior, pose.linear().col(2)), 1e-9);
  EXPECT_NEAR(f.rotation().determinant(), 1.0, 1e-12);
}

TEST(ScrewPlanningFrame, SuperiorHintReplacesTheAxisAndRescuesASteepTilt) {
  const TriangleMesh ellipsoid = planEllipsoid({26.0, 20.0, 13.0}, 48, 96);
  // 50 deg about the left axis: beyond 45 deg the posterior axis is closer
  // to +z than the superior one, so the LPS assignment swaps them (and says
  // it is unsure); the spine's direction as the hint restores them.
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  pose.linear() = Eigen::AngleAxisd(50.0 * kDegPlan, Eigen::Vector3d::UnitX()).toRotationMatrix();
  const TriangleMesh tilted = transformMesh(ellipsoid, pose);
  const VertebraFrame plain = vertebraFrame(tilted);
  EXPECT_TRUE(plain.ambiguous);
  EXPECT_NEAR(plain.confidence, std::sin(50.0 * kDegPlan) - std::cos(50.0 * kDegPlan), 1e-9);
  EXPECT_GT(planAngleBetween(plain.superior, pose.linear().col(2)), 45.0 * kDegPlan);
  EXPECT_FALSE(plain.warnings.empty());

  VertebraFrameOptions options;
  // The spine's direction, 3 deg off the solid's superior axis (turned
  // about its posterior axis) and given pointing inferiorly: it is re-signed.
  const Eigen::AngleAxisd off(3.0 * kDegPlan, pose.linear().col(1));
  const Eigen::Vector3d spine = -(off * pose.linear().col(2)) * 7.0;
  options.superior_hint = spine;
  const VertebraFrame hinted = vertebraFrame(tilted, options);
  EXPECT_TRUE(hinted.superior_from_hint);
  EXPECT_LT((hinted.superior + spine.normalized()).norm(), 1e-12);
  EXPECT_NEAR(hinted.hint_angle, 3.0 * kDegPlan, 1e-9);
  EXPECT_FALSE(hinted.ambiguous);
  EXPECT_GT(hinted.confidence, 0.9);
  // Left is the principal left axis made orthogonal to the hint: the same turn.
  EXPECT_LT((hinted.left - off * pose.linear().col(0)).norm(), 1e-9);
  EXPECT_LT((hinted.posterior - pose.linear().col(1)).norm(), 1e-9);
  EXPECT_NEAR(hinted.left.dot(hinted.superior), 0.0, 1e-12);
  EXPECT_NEAR(hinted.left.dot(hinted.posterior), 0.0, 1e-12);
  EXPECT_LT((hinted.left.cross(hinted.posterior) - hinted.superior).norm(), 1e-12);
  // The principal axes are kept as found.
  EXPECT_LT(planAngleBetween(hinted.principal_axes.col(2), pose.linear().col(2)), 1e-9);
}

TEST(ScrewPlanningFrame, RefusesOpenInsideOutFlatMeshesAndUnusableHints) {
  const TriangleMesh box = planVertebraBox();
  TriangleMesh open = box;
  open.faces.conservativeResize(open.faceCount() - 1, 3);
  try {
    (void)vertebraFrame(open);
    FAIL() << "an open mesh was accepted";
  } catch (const InvalidArgumentError& e) {
    EXPECT_NE(std::string(e.what()).find("not closed"), std::string::npos) << e.what();
  }
  TriangleMesh inside_out = box;
  inside_out.faces.col(1).swap(inside_out.faces.col(2));
  try {
    (void)vertebraFrame(inside_out);
    FAIL() << "an inside-out mesh was accepted";
  } catch (const InvalidArgumentError& e) {
    EXPECT_NE(std::string(e.what()).find("inside-out"), std::string::npos) << e.what();
  }
  // A closed box of zero height: no volume.
  const TriangleMesh flat = planGridBox({-20, -15, 0}, {20, 15, 0}, {planUniform(2), planUniform(2), planUniform(1)});
  ASSERT_TRUE(isClosed(flat));
  try {
    (void)vertebraFrame(flat);
    FAIL() << "a flat mesh was accepted";
  } catch (const InvalidArgumentError& e) {
    EXPECT_NE(std::string(e.what()).find("no volume"), std::string::npos) << e.what();
  }
  EXPECT_THROW((void)vertebraFrame(TriangleMesh{}), InvalidArgumentError);
  VertebraFrameOptions options;
  options.superior_hint = Eigen::Vector3d::Zero();
  EXPECT_THROW((void)vertebraFrame(box, options), InvalidArgumentError);
  options.superior_hint = Eigen::Vector3d(1.0, 0.0, 0.05);  // 87 deg from +z
  EXPECT_THROW((void)vertebraFrame(box, options), InvalidArgumentError);
}

// ===========================================================================
// (a) Synthetic ground truth: angles

TEST(ScrewPlanningAngles, TenDegreesMedialFiveCranialOnEitherSide) {
  const VertebraFrame f = vertebraFrame(planVertebraBox());
  const auto right = screwAngles(planScrew({-12, 15, 0}, planDirection(10, 5, true), 40), f);
  EXPECT_EQ(right.side, "right");
  EXPECT_NEAR(right.medial_deg, 10.0, 1e-9);
  EXPECT_NEAR(right.cranial_deg, 5.0, 1e-9);
  EXPECT_NEAR(right.axial_deg, 10.0, 1e-9);  // towards +left
  EXPECT_NEAR(right.entry_offset_left_mm, -12.0, 1e-9);
  EXPECT_FALSE(right.points_posteriorly);

  const auto left = screwAngles(planScrew({12, 15, 0}, planDirection(10, 5, false), 40), f);
  EXPECT_EQ(left.side, "left");
  EXPECT_NEAR(left.medial_deg, 10.0, 1e-9);
  EXPECT_NEAR(left.cranial_deg, 5.0, 1e-9);
  EXPECT_NEAR(left.axial_deg, -10.0, 1e-9);

  // Diverging (tip lateral of the entry) and caudal.
  const auto diverging = screwAngles(planScrew({-12, 15, 0}, planDirection(-8, -12, true), 40), f);
  EXPECT_NEAR(diverging.medial_deg, -8.0, 1e-9);
  EXPECT_NEAR(diverging.cranial_deg, -12.0, 1e-9);

  // Pointing posteriorly: reported as it is (beyond 90 deg), not flipped.
  const auto backwards = screwAngles(planScrew({-12, 15, 0}, -planDirection(10, 5, true), 40), f);
  EXPECT_TRUE(backwards.points_posteriorly);
  EXPECT_NEAR(backwards.medial_deg, -170.0, 1e-9);
  EXPECT_NEAR(backwards.cranial_deg, -5.0, 1e-9);
  const auto straight_back = screwAngles(planScrew({12, 15, 0}, Eigen::Vector3d::UnitY(), 40), f);
  EXPECT_NEAR(straight_back.medial_deg, 180.0, 1e-9);

  // A midline entry has no medial side.
  const auto midline = screwAngles(planScrew({0.5, 15, 0}, planDirection(10, 5, true), 40), f);
  EXPECT_EQ(midline.side, "midline");
  EXPECT_TRUE(std::isnan(midline.medial_deg));
  EXPECT_NEAR(midline.axial_deg, 10.0, 1e-9);
  // Straight up: no axial projection.
  const auto vertical = screwAngles(planScrew({-12, 15, 0}, Eigen::Vector3d::UnitZ(), 40), f);
  EXPECT_NEAR(vertical.cranial_deg, 90.0, 1e-9);
  EXPECT_TRUE(std::isnan(vertical.medial_deg));
}

TEST(ScrewPlanningAngles, AnglesAreMeasuredInTheVertebrasFrameNotInLps) {
  // A vertebra tilted 20 deg (lordosis) and turned 10 deg (axial rotation):
  // a screw planned 10 deg medial, 5 deg cranial in its frame reads so.
  const TriangleMesh ellipsoid = planEllipsoid({26.0, 20.0, 13.0}, 32, 64);
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  pose.linear() = (Eigen::AngleAxisd(10.0 * kDegPlan, Eigen::Vector3d::UnitZ()) *
                   Eigen::AngleAxisd(20.0 * kDegPlan, Eigen::Vector3d::UnitX()))
                      .toRotationMatrix();
  pose.translation() = Eigen::Vector3d(3.0, -20.0, 80.0);
  const VertebraFrame f = vertebraFrame(transformMesh(ellipsoid, pose));
  const ScrewPath local = planScrew({-12, 15, 0}, planDirection(10, 5, true), 40);
  ScrewPath planned = local;
  planned.entry = pose * local.entry;
  planned.target = pose * local.target;
  const auto a = screwAngles(planned, f);
  EXPECT_EQ(a.side, "right");
  EXPECT_NEAR(a.medial_deg, 10.0, 1e-7);
  EXPECT_NEAR(a.cranial_deg, 5.0, 1e-7);
}

// ===========================================================================
// (a) Synthetic ground truth: breach

TEST(ScrewPlanningBreach, StraightScrewOvershootsTheAnteriorCortexBy5mm) {
  const MeshLocator bone(planVertebraBox());
  // From the posterior face (y = 15) straight anterior, 35 mm: the last 5 mm
  // lie beyond the anterior face (y = -15).
  const auto b = screwBoneBreach(planScrew({5, 15, 0}, -Eigen::Vector3d::UnitY(), 35), bone);
  EXPECT_NEAR(b.entry_to_bone_mm, 0.0, 1e-9);
  EXPECT_NEAR(b.axis_outside_mm, 5.0, 1e-4);
  EXPECT_NEAR(b.length_in_bone_mm, 30.0, 1e-4);
  ASSERT_EQ(b.axis_crossings_mm.size(), 1u);
  EXPECT_NEAR(b.axis_crossings_mm[0], 30.0, 1e-4);
  // The whole circumference leaves at once: bisection to 1/64 of a step.
  EXPECT_NEAR(b.surface_outside_mm, 5.0, 0.5 / 64 + 1e-9);
  EXPECT_NEAR(b.max_breach_mm, 5.0, 1e-9);
  EXPECT_NEAR(b.max_signed_distance_mm, 5.0, 1e-9);
  EXPECT_NEAR(b.depth_of_max_breach_mm, 35.0, 1e-9);
  EXPECT_EQ(b.grade, 3);
  EXPECT_EQ(b.grade_letter, 'D');
  EXPECT_TRUE(b.breached());
  EXPECT_DOUBLE_EQ(b.entry_allowance_mm, 1.75);
  EXPECT_EQ(b.profile.size(), 72u);  // 0, 0.5, ..., 34.5, the tip and the allowance at 1.75
}

TEST(ScrewPlanningBreach, ObliqueScrewLeavesTheSideFaceWithTheClosedFormOvershoot) {
  const MeshLocator bone(planVertebraBox());
  // From (10.13, 15, 0) on the posterior face, 30 deg lateral of anterior,
  // 30 mm long: the axis meets the left face x = 20 at s_c = 9.87 / sin 30;
  // at the tip it is 5.13 mm beyond it and the screw's surface a further
  // r cos 30 (the circle's largest reach along x).
  const double alpha = 30.0 * kDegPlan;
  const double r = 1.75;
  const Eigen::Vector3d d(std::sin(alpha), -std::cos(alpha), 0.0);
  const auto b = screwBoneBreach(planScrew({10.13, 15, 0}, d, 30), bone);
  const double s_c = (20.0 - 10.13) / std::sin(alpha);
  EXPECT_NEAR(b.axis_outside_mm, 30.0 - s_c, 1e-4);
  EXPECT_NEAR(b.length_in_bone_mm, s_c, 1e-4);
  ASSERT_EQ(b.axis_crossings_mm.size(), 1u);
  EXPECT_NEAR(b.axis_crossings_mm[0], s_c, 1e-4);
  const double overshoot = 10.13 + 30.0 * std::sin(alpha) - 20.0 + r * std::cos(alpha);
  // Refined in depth and angle by two rounds of golden sections (the second
  // over a quarter of the first's range): to ~0.005 mm and ~0.3 deg.
  EXPECT_NEAR(b.max_breach_mm, overshoot, 0.01);
  EXPECT_LE(b.max_breach_mm, overshoot + 1e-9) << "no screw point lies farther out than the closed form";
  EXPECT_NEAR(b.depth_of_max_breach_mm, 30.0, 0.01);
  EXPECT_LT((b.max_breach_direction - Eigen::Vector3d(std::cos(alpha), std::sin(alpha), 0.0)).norm(), 0.02);
  EXPECT_EQ(b.grade_letter, 'E');
  EXPECT_EQ(b.grade, 4);
  // The surface leaves where the axis is r cos 30 short of the face. The 12
  // samples reach at worst cos(15 deg) of that, so the sampled exit is later
  // by at most r cos a (1 - cos(pi / 12)) / sin a (plus the bisection).
  const double exact_outside = 30.0 - (20.0 - 10.13 - r * std::cos(alpha)) / std::sin(alpha);
  const double sampling = r * std::cos(alpha) * (1.0 - std::cos(test::kPi / 12.0)) / std::sin(alpha);
  EXPECT_LE(b.surface_outside_mm, exact_outside + 0.5 / 64);
  EXPECT_GE(b.surface_outside_mm, exact_outside - sampling - 0.5 / 64);
  // The circle pokes out of the posterior face near the entry (up to
  // r tan 30 = 1.01 mm), inside the 1.75 mm allowance: not counted.
  EXPECT_NEAR(b.entry_to_bone_mm, 0.0, 1e-9);
}

TEST(ScrewPlanningBreach, ScrewInsideTheBoneIsGradeAWithItsMarginAndSkipsDeepStations) {
  const MeshLocator bone(planVertebraBox());
  // 4 mm screw, 25 mm from the posterior face: its surface comes closest to
  // the cortex at the end of the allowance (2 mm below the entry face).
  const auto b = screwBoneBreach(planScrew({0, 15, 0}, -Eigen::Vector3d::UnitY(), 25, 4.0), bone);
  EXPECT_FALSE(b.breached());
  EXPECT_EQ(b.grade_letter, 'A');
  EXPECT_EQ(b.grade, 0);
  EXPECT_DOUBLE_EQ(b.max_breach_mm, 0.0);
  EXPECT_NEAR(b.max_signed_distance_mm, -2.0, 1e-9);
  EXPECT_NEAR(b.depth_of_max_breach_mm, 2.0, 1e-9);
  EXPECT_DOUBLE_EQ(b.axis_outside_mm, 0.0);
  EXPECT_DOUBLE_EQ(b.surface_outside_mm, 0.0);
  EXPECT_NEAR(b.length_in_bone_mm, 25.0, 1e-9);
  EXPECT_TRUE(b.axis_crossings_mm.empty());
  // Stations whose axis lies deeper than the radius cannot have a surface
  // point outside (the signed distance is 1-Lipschitz): they are skipped.
  const std::size_t full = b.profile.size() * 13;
  EXPECT_LT(b.distance_queries, full / 2) << b.distance_queries << " of " << full;
  std::size_t evaluated = 0;
  for (const auto& s : b.profile) evaluated += s.surface_max_signed_distance_mm.has_value();
  EXPECT_LT(evaluated, 8u);
}

TEST(ScrewPlanningBreach, TheEntryAllowanceIsNotCountedAndAnEntryOffTheBoneIs) {
  const MeshLocator bone(planVertebraBox());
  // Entry 3 mm behind the posterior face.
  const ScrewPath path = planScrew({0, 18, 0}, -Eigen::Vector3d::UnitY(), 30);
  const auto b = screwBoneBreach(path, bone);
  EXPECT_NEAR(b.entry_to_bone_mm, 3.0, 1e-9);
  EXPECT_NEAR(b.length_in_bone_mm, 27.0, 1e-4);
  EXPECT_NEAR(b.axis_outside_mm, 3.0 - 1.75, 1e-4);
  EXPECT_NEAR(b.surface_outside_mm, 3.0 - 1.75, 0.5 / 64 + 1e-9);
  EXPECT_NEAR(b.max_breach_mm, 3.0 - 1.75, 1e-9);
  EXPECT_NEAR(b.depth_of_max_breach_mm, 1.75, 1e-9);
  EXPECT_EQ(b.grade_letter, 'B');
  BreachOptions longer;
  longer.entry_allowance_mm = 3.5;
  const auto c = screwBoneBreach(path, bone, longer);
  EXPECT_FALSE(c.breached());
  EXPECT_DOUBLE_EQ(c.axis_outside_mm, 0.0);
  EXPECT_NEAR(c.max_signed_distance_mm, -0.5, 1e-9);
  EXPECT_NEAR(c.length_in_bone_mm, 27.0, 1e-4) << "the length in bone covers the whole screw";
}

TEST(ScrewPlanningBreach, GertzbeinRobbinsGradesAndRefusals) {
  EXPECT_EQ(gertzbeinRobbinsGrade(0.0), GertzbeinRobbins::A);
  EXPECT_EQ(gertzbeinRobbinsGrade(-1.0), GertzbeinRobbins::A);
  EXPECT_EQ(gertzbeinRobbinsGrade(0.01), GertzbeinRobbins::B);
  EXPECT_EQ(gertzbeinRobbinsGrade(1.99), GertzbeinRobbins::B);
  EXPECT_EQ(gertzbeinRobbinsGrade(2.0), GertzbeinRobbins::C);
  EXPECT_EQ(gertzbeinRobbinsGrade(3.99), GertzbeinRobbins::C);
  EXPECT_EQ(gertzbeinRobbinsGrade(4.0), GertzbeinRobbins::D);
  EXPECT_EQ(gertzbeinRobbinsGrade(6.0), GertzbeinRobbins::E);
  EXPECT_EQ(gertzbeinRobbinsLetter(GertzbeinRobbins::A), 'A');
  EXPECT_EQ(gertzbeinRobbinsLetter(GertzbeinRobbins::E), 'E');

  const TriangleMesh box = planVertebraBox();
  const MeshLocator bone(box);
  const ScrewPath path = planScrew({0, 15, 0}, -Eigen::Vector3d::UnitY(), 25);
  BreachOptions bad;
  bad.step_mm = 0.0;
  EXPECT_THROW((void)screwBoneBreach(path, bone, bad), InvalidArgumentError);
  bad = {};
  bad.circumference_samples = 2;
  EXPECT_THROW((void)screwBoneBreach(path, bone, bad), InvalidArgumentError);
  bad = {};
  bad.entry_allowance_mm = 25.0;
  EXPECT_THROW((void)screwBoneBreach(path, bone, bad), InvalidArgumentError);
  bad.entry_allowance_mm = -1.0;
  EXPECT_THROW((void)screwBoneBreach(path, bone, bad), InvalidArgumentError);
  TriangleMesh open = box;
  open.faces.conservativeResize(open.faceCount() - 1, 3);
  EXPECT_THROW((void)screwBoneBreach(path, MeshLocator(open)), InvalidArgumentError);
  ScrewPath degenerate = path;
  degenerate.target = degenerate.entry;
  EXPECT_THROW((void)screwBoneBreach(degenerate, bone), InvalidArgumentError);
}

// ===========================================================================
// (a) Synthetic ground truth: the planning panel

struct PlanScene {
  TriangleMesh l2_mesh = planVertebraBox();
  TriangleMesh l1_mesh = planVertebraBox({0, 0, 25});  // 5 mm disc gap above L2
  MeshLocator l2{l2_mesh};
  MeshLocator l1{l1_mesh};
  VertebraFrame l2_frame = vertebraFrame(l2_mesh);
  VertebraFrame l1_frame = vertebraFrame(l1_mesh);

  [[nodiscard]] PlanningAnatomy anatomy() const {
    PlanningAnatomy a;
    a.vertebrae.push_back({"L1", &l1, l1_frame});
    a.vertebrae.push_back({"L2", &l2, l2_frame});
    return a;
  }
};

TEST(ScrewPlanningPlan, FiguresForALateralBreachNearAVessel) {
  const PlanScene scene;
  const double alpha = 30.0 * kDegPlan;
  const double r = 1.75;
  const Eigen::Vector3d d(std::sin(alpha), -std::cos(alpha), 0.0);
  const ScrewPath path = planScrew({10.13, 15, 0}, d, 30);
  // A sphere "aorta" (R 8) whose south pole (a vertex) lies 1.2 mm + r from
  // the axis at 15 mm depth, straight above it (z is perpendicular to d).
  const double radius = 8.0;
  const Eigen::Vector3d centre = path.entry + 15.0 * d + Eigen::Vector3d(0, 0, radius + r + 1.2);
  const TriangleMesh sphere = transformMesh(planEllipsoid(Eigen::Vector3d::Constant(radius), 32, 64),
                                            Eigen::Isometry3d(Eigen::Translation3d(centre)));
  const MeshLocator aorta(sphere);
  PlanningAnatomy anatomy = scene.anatomy();
  anatomy.avoidance.push_back({"aorta", StructureKind::Vessel, &aorta});

  const ScrewPlanFigures fig = evaluateScrewPlan(path, anatomy);
  EXPECT_EQ(fig.vertebra, "L2");
  EXPECT_EQ(fig.vertebra_from, VertebraSource::Named);
  EXPECT_TRUE(fig.axis_in_bone_mm.empty());
  ASSERT_TRUE(fig.angles);
  EXPECT_EQ(fig.angles->side, "left");
  EXPECT_NEAR(fig.angles->medial_deg, -30.0, 1e-9);  // diverging
  EXPECT_NEAR(fig.angles->cranial_deg, 0.0, 1e-9);
  ASSERT_TRUE(fig.breach);
  const double overshoot = 10.13 + 30.0 * std::sin(alpha) - 20.0 + r * std::cos(alpha);
  EXPECT_NEAR(fig.breach->max_breach_mm, overshoot, 0.01);
  ASSERT_EQ(fig.clearances.size(), 1u);
  EXPECT_EQ(fig.clearances[0].name, "aorta");
  EXPECT_NEAR(fig.clearances[0].min_clearance_mm, 1.2, 1e-6);
  EXPECT_NEAR(fig.clearances[0].depth_mm, 15.0, 1e-3);
  EXPECT_FALSE(fig.clearances[0].cuts);
  const KindClearance& vessel = fig.closest(StructureKind::Vessel);
  EXPECT_EQ(vessel.structures, 1u);
  ASSERT_TRUE(vessel.min_clearance_mm);
  EXPECT_NEAR(*vessel.min_clearance_mm, 1.2, 1e-6);
  EXPECT_EQ(vessel.name, std::optional<std::string>("aorta"));
  EXPECT_EQ(vessel.closest, std::optional<std::size_t>(0));
  // No neural structure: no number is made up for it.
  const KindClearance& neural = fig.closest(StructureKind::Neural);
  EXPECT_EQ(neural.structures, 0u);
  EXPECT_FALSE(neural.min_clearance_mm);
  EXPECT_FALSE(neural.name);
  EXPECT_FALSE(neural.closest);
  ASSERT_GE(fig.warnings.size(), 2u);
  EXPECT_EQ(fig.warnings[0],
            "breaches the cortex by " + formatFixed(overshoot, 1) + " mm (Gertzbein-Robbins E) at 30 mm, laterally");
  EXPECT_EQ(fig.warnings[1], "within 1.2 mm of aorta at 15 mm");
  EXPECT_EQ(fig.warnings.size(), 2u) << fig.warnings.back();
}

TEST(ScrewPlanningPlan, TheVertebraIsTheOneHoldingTheAxisWhenThePlanNamesNone) {
  const PlanScene scene;
  ScrewPath path = planScrew({-8, 15, 0}, -Eigen::Vector3d::UnitY(), 25, 4.0, "");
  auto fig = evaluateScrewPlan(path, scene.anatomy());
  EXPECT_EQ(fig.vertebra, "L2");
  EXPECT_EQ(fig.vertebra_from, VertebraSource::MostAxisInBone);
  ASSERT_EQ(fig.axis_in_bone_mm.size(), 2u);
  EXPECT_EQ(fig.axis_in_bone_mm[0].first, "L1");
  EXPECT_NEAR(fig.axis_in_bone_mm[0].second, 0.0, 1e-9);
  EXPECT_NEAR(fig.axis_in_bone_mm[1].second, 25.0, 1e-9);
  EXPECT_TRUE(fig.warnings.empty()) << fig.warnings.front();

  path.vertebra = "l2";  // names match regardless of case
  fig = evaluateScrewPlan(path, scene.anatomy());
  EXPECT_EQ(fig.vertebra_from, VertebraSource::Named);

  path.vertebra = "C9";
  fig = evaluateScrewPlan(path, scene.anatomy());
  EXPECT_EQ(fig.vertebra, "L2");
  EXPECT_EQ(fig.vertebra_from, VertebraSource::MostAxisInBone);
  ASSERT_EQ(fig.warnings.size(), 1u);
  EXPECT_EQ(fig.warnings[0],
            "the plan names C9, which is not among the vertebrae; measured against L2 (most of the axis in bone)");

  // Behind L2 and pointing away: in no bone, measured against the nearest.
  path = planScrew({0, 40, 0}, Eigen::Vector3d::UnitY(), 20, 3.5, "");
  fig = evaluateScrewPlan(path, scene.anatomy());
  EXPECT_EQ(fig.vertebra, "L2");
  EXPECT_EQ(fig.vertebra_from, VertebraSource::NearestToEntry);
  EXPECT_NE(std::find(fig.warnings.begin(), fig.warnings.end(),
                      "the screw is in no vertebra; measured against the one nearest to the entry, L2"),
            fig.warnings.end());
  EXPECT_NE(std::find(fig.warnings.begin(), fig.warnings.end(), "the screw points posteriorly"), fig.warnings.end());
  EXPECT_NE(std::find(fig.warnings.begin(), fig.warnings.end(), "entry 25.0 mm outside the bone of L2"),
            fig.warnings.end());
}

TEST(ScrewPlanningPlan, EntryOffTheBoneBackwardsScrewAndMissingPieces) {
  const PlanScene scene;
  // 3.5 mm behind L2's posterior face.
  auto fig = evaluateScrewPlan(planScrew({0, 18.5, 0}, -Eigen::Vector3d::UnitY(), 30), scene.anatomy());
  EXPECT_NEAR(fig.breach->entry_to_bone_mm, 3.5, 1e-9);
  EXPECT_NE(std::find(fig.warnings.begin(), fig.warnings.end(), "entry 3.5 mm outside the bone of L2"),
            fig.warnings.end());
  // Entered from the front and aimed backwards.
  fig = evaluateScrewPlan(planScrew({-8, -15, 0}, Eigen::Vector3d(0.1, 1.0, 0.0), 20), scene.anatomy());
  ASSERT_TRUE(fig.angles);
  EXPECT_TRUE(fig.angles->points_posteriorly);
  EXPECT_GT(std::abs(fig.angles->medial_deg), 90.0);
  EXPECT_NE(std::find(fig.warnings.begin(), fig.warnings.end(), "the screw points posteriorly"), fig.warnings.end());

  // Without the frame: breach yes, angles no, and it says so.
  PlanningAnatomy no_frame;
  no_frame.vertebrae.push_back({"L2", &scene.l2, std::nullopt});
  fig = evaluateScrewPlan(planScrew({0, 15, 0}, -Eigen::Vector3d::UnitY(), 25), no_frame);
  EXPECT_TRUE(fig.breach);
  EXPECT_FALSE(fig.angles);
  EXPECT_EQ(fig.warnings, std::vector<std::string>{"no anatomical frame for L2: angles not computed"});

  // Without any vertebra.
  fig = evaluateScrewPlan(planScrew({0, 15, 0}, -Eigen::Vector3d::UnitY(), 25), PlanningAnatomy{});
  EXPECT_FALSE(fig.breach);
  EXPECT_FALSE(fig.angles);
  EXPECT_EQ(fig.vertebra_from, VertebraSource::None);
  EXPECT_TRUE(fig.vertebra.empty());
  EXPECT_EQ(fig.warnings, std::vector<std::string>{"no vertebra in the anatomy: no angles or breach"});
  for (const auto& k : fig.by_kind) EXPECT_FALSE(k.min_clearance_mm);

  PlanningAnatomy broken = scene.anatomy();
  broken.avoidance.push_back({"aorta", StructureKind::Vessel, nullptr});
  EXPECT_THROW((void)evaluateScrewPlan(planScrew({0, 15, 0}, -Eigen::Vector3d::UnitY(), 25), broken),
               InvalidArgumentError);
  broken = scene.anatomy();
  broken.vertebrae[0].surface = nullptr;
  EXPECT_THROW((void)evaluateScrewPlan(planScrew({0, 15, 0}, -Eigen::Vector3d::UnitY(), 25), broken),
               InvalidArgumentError);
}

TEST(ScrewPlanningPlan, ACutStructureAndOneThatHoldsTheWholeScrewAreNamed) {
  const PlanScene scene;
  const ScrewPath path = planScrew({0, 15, 0}, -Eigen::Vector3d::UnitY(), 25);
  // A cord-like sphere (R 4) centred on the axis at 15 mm: entered at 11 mm.
  const MeshLocator cord(planEllipsoid(Eigen::Vector3d::Constant(4.0), 24, 48));
  // Soft tissue holding the whole screw.
  const MeshLocator tissue(planEllipsoid(Eigen::Vector3d::Constant(60.0), 24, 48));
  PlanningAnatomy anatomy = scene.anatomy();
  anatomy.avoidance.push_back({"spinal cord", StructureKind::Neural, &cord});
  anatomy.avoidance.push_back({"neck", StructureKind::SoftTissue, &tissue});
  const auto fig = evaluateScrewPlan(path, anatomy);
  ASSERT_EQ(fig.clearances.size(), 2u);
  EXPECT_TRUE(fig.clearances[0].cuts);
  EXPECT_FALSE(fig.clearances[0].inside);
  EXPECT_NEAR(fig.clearances[0].min_clearance_mm, -1.75, 1e-9);
  EXPECT_TRUE(fig.clearances[1].cuts);
  EXPECT_TRUE(fig.clearances[1].inside);
  EXPECT_NEAR(fig.clearances[1].min_clearance_mm, -1.75, 1e-9);
  EXPECT_TRUE(fig.closest(StructureKind::Neural).cuts);
  EXPECT_TRUE(fig.closest(StructureKind::SoftTissue).cuts);
  EXPECT_FALSE(fig.closest(StructureKind::Vessel).min_clearance_mm);
  // The cord's pole vertex is on the axis at 15 - 4 = 11 mm.
  EXPECT_NE(std::find(fig.warnings.begin(), fig.warnings.end(), "cuts spinal cord at 11 mm"), fig.warnings.end());
  EXPECT_NE(std::find(fig.warnings.begin(), fig.warnings.end(), "lies inside neck"), fig.warnings.end());
}

// ===========================================================================
// (b) Properties of the math

/// Screws on a vertebra-like (asymmetric) solid: entries inside, off the
/// mid-sagittal plane, leaving the surface 2-6 mm before the tip at a
/// steep enough angle (sin >= 0.5 between axis and surface) that sampling the
/// circumference moves the exit by little.
struct PlanPropertyScrew {
  ScrewPath path;
  double exit_sine = 1.0;
};

std::vector<PlanPropertyScrew> planPropertyScrews(const TriangleMesh& mesh, const VertebraFrame& frame, int count,
                                                  std::uint64_t seed) {
  const MeshLocator locator(mesh);
  const PointsN3 normals = faceNormals(mesh);
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  std::normal_distribution<double> g(0.0, 1.0);
  std::vector<PlanPropertyScrew> out;
  while (static_cast<int>(out.size()) < count) {
    const Eigen::Vector3d entry =
        frame.origin + 6.0 * u(rng) * frame.left + 4.0 * u(rng) * frame.posterior + 3.0 * u(rng) * frame.superior;
    if (std::abs((entry - frame.origin).dot(frame.left)) < 2.0) continue;
    if (locator.signedClosestPoint(entry).signed_distance > -2.0) continue;
    const Eigen::Vector3d d = Eigen::Vector3d(g(rng), g(rng), g(rng)).normalized();
    const auto hits = locator.intersectRay(entry, d);
    if (hits.size() != 1) continue;
    const double sine = std::abs(d.dot(normals.row(hits[0].face).transpose()));
    if (sine < 0.5) continue;
    PlanPropertyScrew s;
    s.path = planScrew(entry, d, hits[0].t + 2.0 + 4.0 * (0.5 + 0.5 * u(rng)));
    s.path.name = "property " + std::to_string(out.size());
    s.exit_sine = sine;
    out.push_back(s);
  }
  return out;
}

/// Breach figures of the same screw measured twice with the circumference
/// sampled from different phases: axis figures agree to the crossing
/// refinement; the surface's exit by the sampling bound at the exit angle;
/// the largest breach, which lies on the tip circle (a station always sits
/// at the tip), to the angular refinement.
void planExpectSameBreach(const BoneBreach& a, const BoneBreach& b, double exit_sine) {
  EXPECT_NEAR(a.entry_to_bone_mm, b.entry_to_bone_mm, 1e-7);
  EXPECT_NEAR(a.length_in_bone_mm, b.length_in_bone_mm, 1e-4);
  EXPECT_NEAR(a.axis_outside_mm, b.axis_outside_mm, 1e-4);
  ASSERT_EQ(a.axis_crossings_mm.size(), b.axis_crossings_mm.size());
  const double r = 1.75;  // planScrew's 3.5 mm screws
  const double sampling = 2.0 * r * (1.0 - std::cos(test::kPi / 12.0)) / exit_sine + 2.0 * 0.5 / 64;
  EXPECT_NEAR(a.surface_outside_mm, b.surface_outside_mm, sampling);
  EXPECT_NEAR(a.max_breach_mm, b.max_breach_mm, 0.005);
  EXPECT_NEAR(a.depth_of_max_breach_mm, b.depth_of_max_breach_mm, 0.05);
  EXPECT_EQ(a.grade, b.grade);
}

TEST(ScrewPlanningProperties, ARigidMotionOfVertebraAndScrewTogetherChangesNoFigure) {
  // The frame is tied to the patient's axes by the assignment, which holds
  // only while the vertebra is turned less than the assignment's limit
  // (45 deg about one axis, confidence cos t - sin t; a 90 deg turn relabels
  // the axes by design). So the motions here turn by at most 15 deg, well
  // inside the ~35 deg the brief expects of real spines, and the solid's
  // confidence is checked to leave room for that.
  const TriangleMesh mesh = test::vertebraLikeMesh(41, 64);
  const VertebraFrame frame = vertebraFrame(mesh);
  ASSERT_GT(frame.confidence, 0.5);
  const auto screws = planPropertyScrews(mesh, frame, 6, 11);
  const MeshLocator bone(mesh);
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> angle(0.0, 15.0 * kDegPlan);
  for (int trial = 0; trial < 4; ++trial) {
    SCOPED_TRACE(trial);
    const Eigen::Isometry3d T = test::randomPerturbation(rng, angle(rng), 50.0, frame.origin);
    const TriangleMesh moved_mesh = transformMesh(mesh, T);
    const VertebraFrame moved = vertebraFrame(moved_mesh);
    EXPECT_LT((moved.origin - T * frame.origin).norm(), 1e-9);
    EXPECT_LT((moved.rotation() - T.linear() * frame.rotation()).norm(), 1e-9);
    EXPECT_LT((moved.extent_mm - frame.extent_mm).norm(), 1e-9);
    EXPECT_NEAR(moved.volume_mm3, frame.volume_mm3, 1e-9 * frame.volume_mm3);
    EXPECT_NEAR(moved.confidence, frame.confidence, 0.5) << "the figure depends on the pose, the frame does not";
    const MeshLocator moved_bone(moved_mesh);
    for (const auto& s : screws) {
      SCOPED_TRACE(s.path.name);
      ScrewPath p = s.path;
      p.entry = T * p.entry;
      p.target = T * p.target;
      const auto a0 = screwAngles(s.path, frame);
      const auto a1 = screwAngles(p, moved);
      EXPECT_EQ(a0.side, a1.side);
      EXPECT_NEAR(a0.medial_deg, a1.medial_deg, 1e-7);
      EXPECT_NEAR(a0.cranial_deg, a1.cranial_deg, 1e-7);
      EXPECT_NEAR(a0.axial_deg, a1.axial_deg, 1e-7);
      planExpectSameBreach(screwBoneBreach(s.path, bone), screwBoneBreach(p, moved_bone), s.exit_sine);
    }
  }
}

TEST(ScrewPlanningProperties, MirroringLeftAndRightFlipsTheSideAndKeepsTheAngles) {
  const TriangleMesh mesh = test::vertebraLikeMesh(41, 64);
  const TriangleMesh mirrored_mesh = planMirror(mesh);
  ASSERT_TRUE(isClosed(mirrored_mesh));
  const VertebraFrame frame = vertebraFrame(mesh);
  const VertebraFrame mirrored = vertebraFrame(mirrored_mesh);
  const Eigen::Matrix3d M = Eigen::Vector3d(-1.0, 1.0, 1.0).asDiagonal();
  EXPECT_LT((mirrored.origin - M * frame.origin).norm(), 1e-9);
  // The mirror image of the left axis points right; the frame's left is its opposite.
  EXPECT_LT((mirrored.left + M * frame.left).norm(), 1e-9);
  EXPECT_LT((mirrored.posterior - M * frame.posterior).norm(), 1e-9);
  EXPECT_LT((mirrored.superior - M * frame.superior).norm(), 1e-9);
  const MeshLocator bone(mesh);
  const MeshLocator mirrored_bone(mirrored_mesh);
  for (const auto& s : planPropertyScrews(mesh, frame, 8, 23)) {
    SCOPED_TRACE(s.path.name);
    ScrewPath p = s.path;
    p.entry = M * p.entry;
    p.target = M * p.target;
    const auto a0 = screwAngles(s.path, frame);
    const auto a1 = screwAngles(p, mirrored);
    EXPECT_NE(a0.side, a1.side);
    EXPECT_TRUE(a1.side == "left" || a1.side == "right");
    EXPECT_NEAR(a0.medial_deg, a1.medial_deg, 1e-7);
    EXPECT_NEAR(a0.cranial_deg, a1.cranial_deg, 1e-7);
    EXPECT_NEAR(a0.axial_deg, -a1.axial_deg, 1e-7);
    EXPECT_NEAR(a0.entry_offset_left_mm, -a1.entry_offset_left_mm, 1e-9);
    planExpectSameBreach(screwBoneBreach(s.path, bone), screwBoneBreach(p, mirrored_bone), s.exit_sine);
  }
}

TEST(ScrewPlanningProperties, TessellationAndOrderOfTheMeshChangeNothing) {
  // Splitting every face into four keeps the surface (the midpoints lie on
  // the faces) and shuffling faces, vertices and corners keeps the solid:
  // the frame and the breach are of the solid, not of its vertices.
  const TriangleMesh mesh = test::vertebraLikeMesh(25, 40);
  const TriangleMesh finer = planShuffle(planSubdivide(mesh), 3);
  ASSERT_TRUE(isClosed(finer));
  const VertebraFrame f0 = vertebraFrame(mesh);
  const VertebraFrame f1 = vertebraFrame(finer);
  EXPECT_LT((f0.origin - f1.origin).norm(), 1e-9);
  EXPECT_LT((f0.rotation() - f1.rotation()).norm(), 1e-9);
  EXPECT_LT((f0.extent_mm - f1.extent_mm).norm(), 1e-9);
  EXPECT_NEAR(f0.volume_mm3, f1.volume_mm3, 1e-9 * f0.volume_mm3);
  const MeshLocator b0(mesh);
  const MeshLocator b1(finer);
  for (const auto& s : planPropertyScrews(mesh, f0, 5, 7)) {
    SCOPED_TRACE(s.path.name);
    const auto x = screwBoneBreach(s.path, b0);
    const auto y = screwBoneBreach(s.path, b1);
    EXPECT_NEAR(x.entry_to_bone_mm, y.entry_to_bone_mm, 1e-9);
    EXPECT_NEAR(x.axis_outside_mm, y.axis_outside_mm, 1e-4);
    EXPECT_NEAR(x.surface_outside_mm, y.surface_outside_mm, 1e-3);
    EXPECT_NEAR(x.max_breach_mm, y.max_breach_mm, 1e-6);
    EXPECT_NEAR(x.length_in_bone_mm, y.length_in_bone_mm, 1e-4);
  }
}

TEST(ScrewPlanningProperties, ReversingTheScrewNegatesCranialAndTurnsTheAxialAngleBy180) {
  const TriangleMesh mesh = test::vertebraLikeMesh(25, 40);
  const VertebraFrame frame = vertebraFrame(mesh);
  for (const auto& s : planPropertyScrews(mesh, frame, 6, 31)) {
    SCOPED_TRACE(s.path.name);
    ScrewPath reversed = s.path;
    reversed.entry = s.path.entry;
    reversed.target = s.path.entry - (s.path.target - s.path.entry);
    const auto a = screwAngles(s.path, frame);
    const auto b = screwAngles(reversed, frame);
    EXPECT_EQ(a.side, b.side);
    EXPECT_NEAR(a.cranial_deg, -b.cranial_deg, 1e-9);
    EXPECT_NEAR(std::remainder(a.axial_deg - b.axial_deg - 180.0, 360.0), 0.0, 1e-9);
    EXPECT_NEAR(std::remainder(a.medial_deg - b.medial_deg - 180.0, 360.0), 0.0, 1e-9);
    EXPECT_NE(a.points_posteriorly, b.points_posteriorly);
    EXPECT_EQ(a.points_posteriorly, std::abs(a.medial_deg) > 90.0);
  }
}

// ===========================================================================
// (c) Real data

/// The volume centroid's neighbours' centroids give the spine's direction.
Eigen::Vector3d planSpineDirection(const VertebraFrame& below, const VertebraFrame& above) {
  return above.origin - below.origin;
}

/// Checks of a real vertebra's frame that follow from anatomy, not from this
/// code: a CT's vertebra is aligned with the patient axes up to its lordosis
/// or kyphosis (lumbar and lower thoracic levels tilt by up to ~25 deg from
/// the scanner's axial plane; the brief's 30 deg bound is used) and is
/// shorter cranio-caudally than it is deep (body plus spinous process);
/// lumbar vertebrae, with their long transverse processes, are also wider
/// than tall (T11-T12's are rudimentary: there width and height are alike).
/// A screw from its centroid straight to the patient's left leaves it.
void planExpectAnatomicalFrame(const LabelMesh& m, const VertebraFrame& f) {
  SCOPED_TRACE(m.name);
  const double limit = 30.0 * kDegPlan;
  EXPECT_LT(planAngleBetween(f.superior, Eigen::Vector3d::UnitZ()), limit);
  EXPECT_LT(planAngleBetween(f.left, Eigen::Vector3d::UnitX()), limit);
  EXPECT_LT(planAngleBetween(f.posterior, Eigen::Vector3d::UnitY()), limit);
  EXPECT_GT(f.alignment, std::cos(limit));
  EXPECT_LT(f.extent_mm.z(), f.extent_mm.y());
  const bool lumbar = m.name.find('L') != std::string::npos;
  if (lumbar) {
    EXPECT_LT(f.extent_mm.z(), f.extent_mm.x());
  }
  EXPECT_NEAR(f.volume_mm3 / 1000.0, m.mesh_volume_ml, 1e-9 * m.mesh_volume_ml);
  EXPECT_NEAR(f.rotation().determinant(), 1.0, 1e-12);
  const MeshLocator bone(m.mesh);
  // The whole vertebra's centroid lies 9.4-14.9 mm from its body's centroid,
  // posteriorly (registration doc, VerSe T9-L5), against body half-depths
  // of ~13.5-18 mm at T9-L5 (body depths 27-36 mm, Panjabi 1991/1992): at
  // the body's posterior wall, inside it or in the canal at most ~1.5 mm
  // behind it (both occur: sub-verse004's T9 and L1 are ~1 mm behind). So:
  // inside, or the ray towards anterior meets the body within 3 mm (1.5 mm
  // plus a voxel) and the one towards posterior meets the arch.
  const double origin_sd = bone.signedClosestPoint(f.origin).signed_distance;
  if (origin_sd >= 0.0) {
    const auto front = bone.intersectRay(f.origin, -f.posterior);
    ASSERT_FALSE(front.empty());
    EXPECT_TRUE(front[0].entering);
    EXPECT_LT(front[0].t, 3.0);
    const auto back = bone.intersectRay(f.origin, f.posterior);
    ASSERT_FALSE(back.empty());
    EXPECT_TRUE(back[0].entering);
  }
  // From the centroid to 10 mm beyond the vertebra's left extent.
  ScrewPath lateral = planScrew(f.origin, f.left, f.extent_max_mm.x() + 10.0, 3.5, m.name);
  const auto b = screwBoneBreach(lateral, bone);
  EXPECT_TRUE(b.breached());
  // Every vertex (so every face) lies at most extent_max along left: the
  // last 10 mm of the axis, and the tip's circle, are at least 10 mm out.
  EXPECT_GE(b.axis_outside_mm, 10.0 - 1e-6);
  EXPECT_GE(b.max_breach_mm, 10.0 - 1e-6);
  EXPECT_NEAR(b.entry_to_bone_mm, origin_sd, 1e-9);
  std::cout << m.name << ": " << m.mesh.faceCount() << " triangles, superior "
            << planAngleBetween(f.superior, Eigen::Vector3d::UnitZ()) / kDegPlan << " deg from +z, extents "
            << f.extent_mm.transpose() << " mm, confidence " << f.confidence << ", separation " << f.moment_separation
            << ", origin at signed distance " << origin_sd << " mm; lateral screw: " << b.axis_outside_mm
            << " mm of axis outside, " << b.max_breach_mm << " mm breach, " << b.distance_queries << " queries\n";
}

TEST(ScrewPlanningRealData, TotalSegmentatorLumbarFramesAreLpsAlignedAndLateralScrewsLeave) {
  MRSNS_REQUIRE_DATA(labels_path, "ct/totalsegmentator/spine_report/example_ct_report/totalseg.nii.gz");
  const ImageVolume labels = io::readImage(labels_path);
  LabelMeshOptions options;
  for (const char* name : {"vertebrae_L4", "vertebrae_L3", "vertebrae_L2", "vertebrae_L1"}) {
    options.labels.push_back(*totalSegmentatorLabel(name));
  }
  const auto result = meshLabelMap(labels, options);
  ASSERT_EQ(result.meshes.size(), 4U);  // ascending label: L4 (28) .. L1 (31)
  std::vector<VertebraFrame> frames;
  for (const auto& m : result.meshes) {
    ASSERT_TRUE(m.closed) << m.name;
    frames.push_back(vertebraFrame(m.mesh));
    planExpectAnatomicalFrame(m, frames.back());
    // Here the lumbar bodies hold their vertebra's centroid (the brief's check).
    EXPECT_LT(MeshLocator(m.mesh).signedClosestPoint(frames.back().origin).signed_distance, 0.0) << m.name;
  }
  // L3 and L2 with the spine's direction from their neighbours: the hint is
  // the superior axis, within the same lordosis bound of +z, and the frame
  // stays right-handed and close to the patient's left.
  for (std::size_t i = 1; i + 1 < frames.size(); ++i) {
    SCOPED_TRACE(result.meshes[i].name);
    VertebraFrameOptions hinted;
    hinted.superior_hint = planSpineDirection(frames[i - 1], frames[i + 1]);
    EXPECT_LT(planAngleBetween(*hinted.superior_hint, Eigen::Vector3d::UnitZ()), 30.0 * kDegPlan);
    const VertebraFrame f = vertebraFrame(result.meshes[i].mesh, hinted);
    EXPECT_LT((f.superior - hinted.superior_hint->normalized()).norm(), 1e-12);
    EXPECT_LT(planAngleBetween(f.left, Eigen::Vector3d::UnitX()), 30.0 * kDegPlan);
    EXPECT_LT((f.left.cross(f.posterior) - f.superior).norm(), 1e-12);
    std::cout << result.meshes[i].name << ": spine direction " << f.hint_angle / kDegPlan
              << " deg from the principal superior axis\n";
  }
}

TEST(ScrewPlanningRealData, VerseThoracolumbarFramesAreLpsAligned) {
  MRSNS_REQUIRE_DATA(mask_path, "ct/verse/sub-verse004_seg-vert_msk.nii.gz");
  const ImageVolume labels = io::readImage(mask_path);
  LabelMeshOptions options;
  options.target_triangles = 20000;
  const auto result = meshLabelMap(labels, options);
  ASSERT_EQ(result.meshes.size(), 9U);  // T9..L5
  for (const auto& m : result.meshes) {
    ASSERT_TRUE(m.closed) << m.name;
    planExpectAnatomicalFrame(m, vertebraFrame(m.mesh));
  }
}

TEST(ScrewPlanningRealData, PhantomPedicleScrewsReadTheirDesignedAnglesAndStayInTheBone) {
  // The phantom's vertebrae are mirror-symmetric about their x = 0 plane,
  // which is the grid's (voxel centres symmetric about 0), so the meshed
  // vertebra's principal left axis is the phantom's; with the phantom's spine
  // axis as the hint its frame is the phantom's own. Its planned screws run
  // along the pedicle capsules in the axial plane: ~45 deg medial, 0 cranial.
  PhantomOptions options;
  options.spacing_mm = 1.0;
  options.noise_sigma_hu = 0.0;
  const CervicalPhantom phantom = generateCervicalPhantom(options);
  const double h = options.spacing_mm;
  LabelMeshOptions bone_options;
  bone_options.labels = {5, 6};
  const auto bones = meshLabelMap(phantom.bone_labels, bone_options);
  ASSERT_EQ(bones.meshes.size(), 2U);
  LabelMeshOptions vessel_options;
  vessel_options.labels = {kPhantomVesselLabel};
  const auto vessel_meshes = meshLabelMap(phantom.labels, vessel_options);
  ASSERT_EQ(vessel_meshes.meshes.size(), 1U);
  const MeshLocator vessel(vessel_meshes.meshes[0].mesh);

  std::vector<MeshLocator> locators;
  locators.reserve(2);
  PlanningAnatomy anatomy;
  anatomy.avoidance.push_back({"carotid", StructureKind::Vessel, &vessel});
  std::map<std::string, VertebraFrame> truth;
  for (const auto& m : bones.meshes) {
    const PhantomVertebra& v = phantom.vertebrae[static_cast<std::size_t>(m.label - 3)];
    ASSERT_EQ(v.name, m.name);
    VertebraFrameOptions hinted;
    hinted.superior_hint = v.rotation.col(2);
    const VertebraFrame f = vertebraFrame(m.mesh, hinted);
    EXPECT_LT(planAngleBetween(f.left, v.rotation.col(0)), 0.5 * kDegPlan) << m.name;
    locators.emplace_back(m.mesh);
    anatomy.vertebrae.push_back({m.name, &locators.back(), f});
    VertebraFrame t;
    t.origin = v.body_center;
    t.left = v.rotation.col(0);
    t.posterior = v.rotation.col(1);
    t.superior = v.rotation.col(2);
    truth[m.name] = t;
  }
  ASSERT_EQ(phantom.screw_paths.size(), 4U);
  for (const ScrewPath& path : phantom.screw_paths) {
    SCOPED_TRACE(path.name);
    const auto fig = evaluateScrewPlan(path, anatomy);
    EXPECT_EQ(fig.vertebra, path.vertebra);
    ASSERT_TRUE(fig.angles);
    const auto expected = screwAngles(path, truth.at(path.vertebra));
    EXPECT_NEAR(expected.cranial_deg, 0.0, 1e-9);
    EXPECT_NEAR(expected.medial_deg, 45.0, 1.0);
    EXPECT_EQ(fig.angles->side, expected.side);
    EXPECT_EQ(fig.angles->side, path.name.substr(path.name.find(' ') + 1));
    EXPECT_NEAR(fig.angles->medial_deg, expected.medial_deg, 0.5);
    EXPECT_NEAR(fig.angles->cranial_deg, expected.cranial_deg, 0.5);
    // Entry on the analytic surface; the mesh within a voxel of it.
    ASSERT_TRUE(fig.breach);
    EXPECT_LT(std::abs(fig.breach->entry_to_bone_mm), h);
    // Pedicle radius 2.7 mm around the axis vs the screw's 1.75: 0.95 mm of
    // bone around the thread, more than the mesh's half-voxel error.
    EXPECT_FALSE(fig.breach->breached()) << fig.breach->max_breach_mm << " mm at " << fig.breach->depth_of_max_breach_mm
                                         << " mm";
    // The carotid is a tube along z (outer radius 4.3 mm): its clearance is
    // the axis's distance to the tube's line in the axial plane less both
    // radii, the mesh within a voxel of the tube.
    const Eigen::Vector2d c = phantom.vessel_center.head<2>();
    const Eigen::Vector2d e = path.entry.head<2>();
    const Eigen::Vector2d t = path.tip().head<2>();
    const double s = std::clamp((c - e).dot(t - e) / (t - e).squaredNorm(), 0.0, 1.0);
    const double analytic = (e + s * (t - e) - c).norm() - phantom.vessel_outer_radius_mm - 0.5 * path.diameter_mm;
    ASSERT_EQ(fig.clearances.size(), 1U);
    EXPECT_NEAR(fig.clearances[0].min_clearance_mm, analytic, h);
    std::cout << path.name << ": medial " << fig.angles->medial_deg << " (designed " << expected.medial_deg
              << "), cranial " << fig.angles->cranial_deg << ", thread " << -fig.breach->max_signed_distance_mm
              << " mm inside the cortex at its closest (" << fig.breach->depth_of_max_breach_mm
              << " mm), carotid clearance " << fig.clearances[0].min_clearance_mm << " mm (analytic " << analytic
              << ")\n";
  }
}

}  // namespace screw_planning_test
}  // namespace mrsns::registration
