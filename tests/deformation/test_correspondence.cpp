// Correspondence for meshes not in correspondence: a known smooth
// deformation recovered across different tessellations, the real femur
// pair, and bad input.
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

#include "../support/test_data.h"
#include "mrsns/core/error.h"
#include "mrsns/core/mesh_ops.h"
#include "mrsns/deformation/correspondence.h"
#include "mrsns/deformation/model_building.h"
#include "mrsns/io/landmarks_io.h"
#include "mrsns/io/mesh_io.h"

namespace mrsns::deformation {
namespace {

// A closed ellipsoid (radii a, b, c) as a latitude/longitude mesh with
// `rings` latitude steps and `sectors` longitude steps, starting at `phase`.
TriangleMesh ellipsoid(int rings, int sectors, double phase, const Eigen::Vector3d& radii) {
  TriangleMesh m;
  const int n = 2 + (rings - 1) * sectors;
  m.vertices.resize(n, 3);
  m.vertices.row(0) << 0.0, 0.0, radii.z();
  m.vertices.row(n - 1) << 0.0, 0.0, -radii.z();
  for (int i = 1; i < rings; ++i) {
    const double th = std::numbers::pi * i / rings;
    for (int j = 0; j < sectors; ++j) {
      const double ph = 2.0 * std::numbers::pi * j / sectors + phase;
      m.vertices.row(1 + (i - 1) * sectors + j) << radii.x() * std::sin(th) * std::cos(ph),
          radii.y() * std::sin(th) * std::sin(ph), radii.z() * std::cos(th);
    }
  }
  std::vector<Eigen::Vector3i> f;
  auto at = [&](int i, int j) { return 1 + (i - 1) * sectors + ((j % sectors) + sectors) % sectors; };
  for (int j = 0; j < sectors; ++j) f.emplace_back(0, at(1, j), at(1, j + 1));
  for (int i = 1; i + 1 < rings; ++i) {
    for (int j = 0; j < sectors; ++j) {
      f.emplace_back(at(i, j), at(i + 1, j), at(i + 1, j + 1));
      f.emplace_back(at(i, j), at(i + 1, j + 1), at(i, j + 1));
    }
  }
  for (int j = 0; j < sectors; ++j) f.emplace_back(n - 1, at(rings - 1, j + 1), at(rings - 1, j));
  m.faces.resize(static_cast<Eigen::Index>(f.size()), 3);
  for (std::size_t k = 0; k < f.size(); ++k) m.faces.row(static_cast<Eigen::Index>(k)) = f[k].transpose();
  return m;
}

// A smooth, non-rigid deformation (amplitudes 2-3 mm, wavelengths > 90 mm).
Eigen::Vector3d warp(const Eigen::Vector3d& p) {
  return p + Eigen::Vector3d(3.0 * std::sin(p.y() / 15.0), 2.0 * std::cos(p.x() / 20.0) - 2.0,
                             2.5 * std::sin(p.x() / 25.0 + p.z() / 15.0));
}

TriangleMesh warped(TriangleMesh m) {
  for (Eigen::Index i = 0; i < m.vertexCount(); ++i)
    m.vertices.row(i) = warp(m.vertices.row(i).transpose()).transpose();
  return m;
}

// Four landmarks at the ends of the axes (+x, -x, +y, +z) mapped by `f`:
// the ellipsoid is symmetric, so without them its principal axes could
// align it flipped.
template <typename F>
std::vector<Eigen::Vector3d> axisLandmarks(const Eigen::Vector3d& radii, F f) {
  return {f(Eigen::Vector3d(radii.x(), 0, 0)), f(Eigen::Vector3d(-radii.x(), 0, 0)),
          f(Eigen::Vector3d(0, radii.y(), 0)), f(Eigen::Vector3d(0, 0, radii.z()))};
}

TEST(NonRigidCorrespondence, RecoversAKnownSmoothDeformationAcrossTessellations) {
  const Eigen::Vector3d radii(30.0, 20.0, 15.0);
  const TriangleMesh reference = ellipsoid(24, 48, 0.0, radii);
  // The example: another tessellation (finer, rotated longitudes), warped.
  const TriangleMesh example = warped(ellipsoid(37, 71, 0.37, radii));
  NonRigidFitOptions o;
  o.estimate_scale = false;
  const auto id = [](const Eigen::Vector3d& p) { return p; };
  const NonRigidFitResult fit =
      fitReferenceToExample(reference, example, o, axisLandmarks(radii, id), axisLandmarks(radii, warp));
  // Resampling error: the example's chords sag below the smooth surface by
  // up to r (1 - cos(pi / sectors)) ~ 0.06 mm with r = 30 mm, 71 sectors;
  // the reference's chords the same with 48 sectors (0.064 mm at its edge
  // midpoints). Vertex distances are bounded by the sum.
  const double sag =
      30.0 * (1.0 - std::cos(std::numbers::pi / 48.0)) + 30.0 * (1.0 - std::cos(std::numbers::pi / 71.0));
  EXPECT_LT(fit.fitted_to_example.mean, sag);
  EXPECT_LT(fit.example_to_fitted.mean, sag);
  EXPECT_LT(fit.fitted_to_example.max, 4.0 * sag + 0.1 * fit.mean_edge_length_mm);
  // Correspondence: each fitted vertex against where the warp took it. Across
  // the surface (along its normal) the error is bounded by the resampling
  // error; along the surface a smooth featureless shape does not show where a
  // point slid (only landmarks or features would), so there the fit only has
  // to be no worse than the rigid stage.
  const PointsN3 normals = vertexNormals(fit.fitted);
  double sum = 0.0, normal_sum = 0.0, rigid_sum = 0.0;
  for (Eigen::Index i = 0; i < reference.vertexCount(); ++i) {
    const Eigen::Vector3d p = reference.vertices.row(i).transpose();
    const Eigen::Vector3d e = fit.fitted.vertices.row(i).transpose() - warp(p);
    sum += e.norm();
    normal_sum += std::abs(e.dot(normals.row(i).transpose()));
    rigid_sum += (fit.example_T_reference * p - warp(p)).norm();
  }
  const double count = static_cast<double>(reference.vertexCount());
  std::cout << "synthetic: edge " << fit.mean_edge_length_mm << " mm; correspondence error rigid " << rigid_sum / count
            << " mm, fitted " << sum / count << " mm (normal part " << normal_sum / count << " mm); surface "
            << fit.fitted_to_example.mean << " / " << fit.example_to_fitted.mean << " mm\n";
  EXPECT_LT(sum, rigid_sum);
  // The rigid stage alone leaves the warp (mm-sized) in place.
  EXPECT_GT(fit.rigid_mean_distance_mm, 5.0 * fit.fitted_to_example.mean);
}

// Displacement along the ellipsoid's normal (bumps of up to 2 mm): the true
// correspondence is observable, as nothing slides along the surface.
Eigen::Vector3d bump(const Eigen::Vector3d& p, const Eigen::Vector3d& radii) {
  const Eigen::Vector3d n = p.cwiseQuotient(radii.cwiseProduct(radii)).normalized();
  return p + 2.0 * std::sin(p.x() / 9.0) * std::cos(p.y() / 7.0) * n;
}

TEST(NonRigidCorrespondence, RecoversANormalDeformationVertexByVertex) {
  const Eigen::Vector3d radii(30.0, 20.0, 15.0);
  const TriangleMesh reference = ellipsoid(24, 48, 0.0, radii);
  TriangleMesh example = ellipsoid(37, 71, 0.37, radii);
  for (Eigen::Index i = 0; i < example.vertexCount(); ++i) {
    example.vertices.row(i) = bump(example.vertices.row(i).transpose(), radii).transpose();
  }
  NonRigidFitOptions o;
  o.estimate_scale = false;
  const auto id = [](const Eigen::Vector3d& p) { return p; };
  const auto b = [&radii](const Eigen::Vector3d& p) { return bump(p, radii); };
  const NonRigidFitResult fit =
      fitReferenceToExample(reference, example, o, axisLandmarks(radii, id), axisLandmarks(radii, b));
  double sum = 0.0, worst = 0.0, rigid_sum = 0.0;
  for (Eigen::Index i = 0; i < reference.vertexCount(); ++i) {
    const Eigen::Vector3d p = reference.vertices.row(i).transpose();
    const double e = (fit.fitted.vertices.row(i).transpose() - bump(p, radii)).norm();
    sum += e;
    worst = std::max(worst, e);
    rigid_sum += (fit.example_T_reference * p - bump(p, radii)).norm();
  }
  const double count = static_cast<double>(reference.vertexCount());
  std::cout << "normal bumps: correspondence error rigid " << rigid_sum / count << " mm, fitted " << sum / count
            << " mm, max " << worst << " mm; surface " << fit.fitted_to_example.mean << " / "
            << fit.example_to_fitted.mean << " mm\n";
  const double sag =
      30.0 * (1.0 - std::cos(std::numbers::pi / 48.0)) + 30.0 * (1.0 - std::cos(std::numbers::pi / 71.0));
  EXPECT_LT(fit.fitted_to_example.mean, 2.0 * sag);
  // The fit halves the error at least; what remains is sliding along the
  // bumps' flanks, which closest-point correspondences allow (~0.4 mm here).
  EXPECT_LT(sum / count, 0.5 * rigid_sum / count);
  EXPECT_LT(worst, 2.0);  // never beyond the bump amplitude
}

TEST(NonRigidCorrespondence, FittedExamplesBuildAModelWithTheReferenceTopology) {
  const Eigen::Vector3d radii(30.0, 20.0, 15.0);
  const TriangleMesh reference = ellipsoid(16, 32, 0.0, radii);
  std::vector<TriangleMesh> examples;
  std::vector<std::vector<Eigen::Vector3d>> landmarks;
  for (int k = 0; k < 4; ++k) {
    const double s = 1.0 + 0.05 * k;
    examples.push_back(ellipsoid(21 + 2 * k, 41 + 3 * k, 0.2 * k, radii * s));
    landmarks.push_back(axisLandmarks(radii, [s](const Eigen::Vector3d& p) { return Eigen::Vector3d(s * p); }));
  }
  const auto id = [](const Eigen::Vector3d& p) { return p; };
  const auto fits = establishCorrespondence(reference, examples, {}, landmarks, axisLandmarks(radii, id));
  ASSERT_EQ(fits.size(), examples.size());
  std::vector<TriangleMesh> fitted;
  for (const auto& f : fits) {
    EXPECT_EQ(f.fitted.vertexCount(), reference.vertexCount());
    EXPECT_LT(f.fitted_to_example.mean, 0.2);
    fitted.push_back(f.fitted);
  }
  ShapeModelBuildOptions b;
  b.align = false;
  const auto model = buildShapeModel(fitted, b);
  // Examples differ by an isotropic size change only: one dominant mode.
  ASSERT_GE(model.model.modeCount(), 1);
  EXPECT_GT(model.model.variances[0] / model.model.variances.sum(), 0.95);
}

TEST(NonRigidCorrespondence, RealFemurPairFitsWithinTheMeshResolution) {
  MRSNS_REQUIRE_DATA(ref_path, "ssm/statismo/femur_meshes/VSD001_femur.vtk");
  MRSNS_REQUIRE_DATA(ex_path, "ssm/statismo/femur_meshes/VSD002_femur.vtk");
  MRSNS_REQUIRE_DATA(ref_lm_path, "ssm/statismo/femur_meshes/VSD001-lm.csv");
  MRSNS_REQUIRE_DATA(ex_lm_path, "ssm/statismo/femur_meshes/VSD002-lm.csv");
  const TriangleMesh reference = io::readMesh(ref_path);
  const TriangleMesh example = io::readMesh(ex_path);
  std::vector<Eigen::Vector3d> ref_lm, ex_lm;
  for (const auto& l : io::readLandmarks(ref_lm_path).points) ref_lm.push_back(l.position);
  for (const auto& l : io::readLandmarks(ex_lm_path).points) ex_lm.push_back(l.position);
  ASSERT_EQ(ref_lm.size(), 4u);
  ASSERT_EQ(ex_lm.size(), 4u);
  const NonRigidFitResult fit = fitReferenceToExample(reference, example, {}, ref_lm, ex_lm);
  double lm_mean = 0.0, lm_rigid = 0.0;
  for (std::size_t k = 0; k < 4; ++k) {
    lm_mean += fit.landmark_error_mm[k] / 4.0;
    lm_rigid += fit.rigid_landmark_error_mm[k] / 4.0;
  }
  RecordProperty("surface_mean_mm", std::to_string(fit.fitted_to_example.mean));
  RecordProperty("surface_max_mm", std::to_string(fit.fitted_to_example.max));
  RecordProperty("landmark_mean_mm", std::to_string(lm_mean));
  std::cout << "femur fit: edge " << fit.mean_edge_length_mm << " mm, scale " << fit.scale << ", rigid mean "
            << fit.rigid_mean_distance_mm << " mm, fitted->example mean " << fit.fitted_to_example.mean << " max "
            << fit.fitted_to_example.max << ", example->fitted mean " << fit.example_to_fitted.mean << " max "
            << fit.example_to_fitted.max << ", landmarks rigid " << lm_rigid << " fitted " << lm_mean << " mm\n";
  const double h = fit.mean_edge_length_mm;
  EXPECT_LT(fit.fitted_to_example.mean, 0.25 * h);
  EXPECT_LT(fit.example_to_fitted.mean, 0.25 * h);
  EXPECT_LT(fit.fitted_to_example.max, 3.0 * h);
  EXPECT_LT(fit.rigid_mean_distance_mm, 10.0);
  EXPECT_LT(fit.fitted_to_example.mean, 0.5 * fit.rigid_mean_distance_mm);
  EXPECT_LT(lm_mean, 3.0 * h);
}

TEST(NonRigidCorrespondence, BadInputIsRefusedWithAClearError) {
  const TriangleMesh m = ellipsoid(8, 16, 0.0, Eigen::Vector3d(10, 8, 6));
  const std::vector<Eigen::Vector3d> three{{0, 0, 1}, {1, 0, 0}, {0, 1, 0}};
  const std::vector<Eigen::Vector3d> two{{0, 0, 1}, {1, 0, 0}};
  EXPECT_THROW((void)fitReferenceToExample(m, TriangleMesh{}), InvalidArgumentError);
  EXPECT_THROW((void)fitReferenceToExample(m, m, {}, three, two), InvalidArgumentError);
  NonRigidFitOptions o;
  o.stiffness.clear();
  EXPECT_THROW((void)fitReferenceToExample(m, m, o), InvalidArgumentError);
  o.stiffness = {-1.0};
  EXPECT_THROW((void)fitReferenceToExample(m, m, o), InvalidArgumentError);
}

}  // namespace
}  // namespace mrsns::deformation
