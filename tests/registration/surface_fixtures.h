#pragma once
// Synthetic surfaces and point sets with known geometry for the ICP,
// fiducial and screw-path tests and the ICP benchmark.
#include <Eigen/Geometry>
#include <cmath>
#include <random>
#include <vector>

#include "mrsns/core/mesh.h"
#include "mrsns/core/mesh_ops.h"
#include "mrsns/core/rigid.h"

namespace mrsns::test {

constexpr double kPi = 3.14159265358979323846;
constexpr double kDegree = kPi / 180.0;

/// Radius factor of the vertebra-like shape in direction u (unit): an
/// ellipsoid with low-order bumps and two lobes (a "spinous process" and a
/// "transverse process" on one side only) so no rotation maps it onto itself.
inline Eigen::Vector3d centroid(const std::vector<Eigen::Vector3d>& points) {
  Eigen::Vector3d c = Eigen::Vector3d::Zero();
  for (const auto& p : points) c += p;
  return c / static_cast<double>(points.size());
}

inline double vertebraRadius(const Eigen::Vector3d& u) {
  const double theta = std::acos(std::clamp(u.z(), -1.0, 1.0));
  const double phi = std::atan2(u.y(), u.x());
  const Eigen::Vector3d d1 = Eigen::Vector3d(0.0, -1.0, 0.3).normalized();
  const Eigen::Vector3d d2 = Eigen::Vector3d(0.7, 0.5, -0.2).normalized();
  return 1.0 + 0.12 * std::sin(3.0 * theta) * std::cos(2.0 * phi + 0.3) +
         0.08 * std::cos(4.0 * phi) * std::sin(theta) * std::sin(theta) +
         0.45 * std::exp(-(u - d1).squaredNorm() / 0.12) + 0.25 * std::exp(-(u - d2).squaredNorm() / 0.08);
}

/// A closed, star-shaped, non-symmetric surface about 40 x 28 x 22 mm (plus
/// lobes), centred at the origin, wound counter-clockwise seen from outside.
/// 2 * segments * (rings - 1) triangles.
inline TriangleMesh vertebraLikeMesh(int rings, int segments) {
  const Eigen::Vector3d semi_axes(20.0, 14.0, 11.0);
  const auto point = [&](double theta, double phi) -> Eigen::Vector3d {
    const Eigen::Vector3d u(std::sin(theta) * std::cos(phi), std::sin(theta) * std::sin(phi), std::cos(theta));
    return semi_axes.cwiseProduct(u) * vertebraRadius(u);
  };
  TriangleMesh mesh;
  mesh.name = "vertebra-like";
  const int n = 2 + (rings - 1) * segments;
  mesh.vertices.resize(n, 3);
  mesh.vertices.row(0) = point(0.0, 0.0).transpose();
  for (int i = 1; i < rings; ++i) {
    for (int j = 0; j < segments; ++j) {
      mesh.vertices.row(1 + (i - 1) * segments + j) = point(kPi * i / rings, 2.0 * kPi * j / segments).transpose();
    }
  }
  mesh.vertices.row(n - 1) = point(kPi, 0.0).transpose();
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

/// `count` points uniformly distributed over the surface area (seeded), each
/// moved by isotropic Gaussian noise of `sigma_per_axis` mm per axis.
inline std::vector<Eigen::Vector3d> sampleSurface(const TriangleMesh& mesh, int count, double sigma_per_axis,
                                                  std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  const Eigen::VectorXd areas = faceAreas(mesh);
  std::discrete_distribution<Eigen::Index> pick_face(areas.data(), areas.data() + areas.size());
  std::uniform_real_distribution<double> uniform(0.0, 1.0);
  std::normal_distribution<double> noise(0.0, sigma_per_axis > 0.0 ? sigma_per_axis : 1.0);
  std::vector<Eigen::Vector3d> points;
  points.reserve(static_cast<std::size_t>(count));
  for (int k = 0; k < count; ++k) {
    const Eigen::Index f = pick_face(rng);
    double a = uniform(rng);
    double b = uniform(rng);
    if (a + b > 1.0) {
      a = 1.0 - a;
      b = 1.0 - b;
    }
    const Eigen::Vector3d p0 = mesh.vertices.row(mesh.faces(f, 0)).transpose();
    const Eigen::Vector3d p1 = mesh.vertices.row(mesh.faces(f, 1)).transpose();
    const Eigen::Vector3d p2 = mesh.vertices.row(mesh.faces(f, 2)).transpose();
    Eigen::Vector3d p = p0 + a * (p1 - p0) + b * (p2 - p0);
    if (sigma_per_axis > 0.0) p += Eigen::Vector3d(noise(rng), noise(rng), noise(rng));
    points.push_back(p);
  }
  return points;
}

inline std::vector<Eigen::Vector3d> transformPoints(const Eigen::Isometry3d& T,
                                                    const std::vector<Eigen::Vector3d>& in) {
  std::vector<Eigen::Vector3d> out;
  out.reserve(in.size());
  for (const auto& p : in) out.push_back(T * p);
  return out;
}

inline Eigen::Isometry3d makePose(const Eigen::Vector3d& rotation_vector, const Eigen::Vector3d& translation) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = so3Exp(rotation_vector);
  T.translation() = translation;
  return T;
}

/// A random perturbation: rotation of exactly `angle` about a random axis
/// through `centre` followed by a translation of exactly `distance` in a
/// random direction.
inline Eigen::Isometry3d randomPerturbation(std::mt19937_64& rng, double angle, double distance,
                                            const Eigen::Vector3d& centre) {
  std::normal_distribution<double> g(0.0, 1.0);
  const Eigen::Vector3d axis = Eigen::Vector3d(g(rng), g(rng), g(rng)).normalized();
  const Eigen::Vector3d dir = Eigen::Vector3d(g(rng), g(rng), g(rng)).normalized();
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = so3Exp(angle * axis);
  T.translation() = centre - T.linear() * centre + distance * dir;
  return T;
}

/// Rotation (radians) and translation (mm, at `at`) differences of two transforms.
struct PoseError {
  double rotation = 0.0;
  double translation = 0.0;
};
inline PoseError poseError(const Eigen::Isometry3d& estimate, const Eigen::Isometry3d& truth,
                           const Eigen::Vector3d& at = Eigen::Vector3d::Zero()) {
  return {rotationAngleBetween(estimate.linear(), truth.linear()), (estimate * at - truth * at).norm()};
}

/// A closed cylinder along +z from z0 to z1 (radius r), `rings` vertex rings.
inline TriangleMesh cylinderMesh(double r, double z0, double z1, int rings, int segments) {
  TriangleMesh m;
  const int n = rings * segments + 2;
  m.vertices.resize(n, 3);
  for (int i = 0; i < rings; ++i) {
    const double z = z0 + (z1 - z0) * i / (rings - 1);
    for (int j = 0; j < segments; ++j) {
      const double a = 2.0 * kPi * j / segments;
      m.vertices.row(i * segments + j) << r * std::cos(a), r * std::sin(a), z;
    }
  }
  m.vertices.row(n - 2) << 0.0, 0.0, z0;
  m.vertices.row(n - 1) << 0.0, 0.0, z1;
  std::vector<Eigen::Vector3i> f;
  for (int i = 0; i + 1 < rings; ++i) {
    for (int j = 0; j < segments; ++j) {
      const int a = i * segments + j, b = i * segments + (j + 1) % segments;
      const int c = a + segments, d = b + segments;
      f.emplace_back(a, b, d);
      f.emplace_back(a, d, c);
    }
  }
  for (int j = 0; j < segments; ++j) {
    f.emplace_back(n - 2, (j + 1) % segments, j);
    f.emplace_back(n - 1, (rings - 1) * segments + j, (rings - 1) * segments + (j + 1) % segments);
  }
  m.faces.resize(static_cast<Eigen::Index>(f.size()), 3);
  for (std::size_t k = 0; k < f.size(); ++k) m.faces.row(static_cast<Eigen::Index>(k)) = f[k].transpose();
  return m;
}

struct Screw {
  Eigen::Vector3d entry;  ///< where the axis meets the bone surface (the truth)
  Eigen::Vector3d axis;   ///< unit, outwards
};

/// A fiducial screw: shaft radius 1 mm from 8 mm inside the bone to 3 mm
/// outside, head radius 2 mm from 3 to 5 mm outside, along `axis` through `entry`.
inline TriangleMesh screwMesh(const Screw& s) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = Eigen::Quaterniond::FromTwoVectors(Eigen::Vector3d::UnitZ(), s.axis).toRotationMatrix();
  T.translation() = s.entry;
  const TriangleMesh parts[2] = {transformMesh(cylinderMesh(1.0, -8.0, 3.0, 23, 16), T),
                                 transformMesh(cylinderMesh(2.0, 3.0, 5.0, 5, 24), T)};
  return mergeMeshes(parts);
}

}  // namespace mrsns::test
