#include "mrsns/deformation/vessel_phantom.h"

#include <Eigen/Geometry>
#include <cmath>
#include <numbers>

#include "mrsns/core/error.h"

namespace mrsns::deformation {
namespace {

int ringCount(double length, double spacing) {
  return static_cast<int>(std::lround(length / spacing)) + 1;
}

// Centre line of branch b at fraction s in [0, 1] before deformation.
Eigen::Vector3d centreLine(int b, double s, const VesselPhantomOptions& o, double spread) {
  if (b == 0) return {0.0, 0.0, -o.cca_length_mm * (1.0 - s)};
  // Branches leave the bifurcation (z = 0) and diverge smoothly.
  const double side = b == 1 ? 1.0 : -1.0;
  const double start = b == 1 ? 1.0 : 1.4;  // start offset inside the CCA end
  const double x =
      side * (start + (0.5 * spread - start) * (1.0 - std::cos(std::numbers::pi * std::min(1.0, 1.6 * s))) / 2.0);
  return {x, 0.0, o.branch_length_mm * s};
}

}  // namespace

VesselDeformation randomVesselDeformation(std::mt19937_64& rng, int pull_count, double amplitude_mm, double radius_sd,
                                          double spread_sd) {
  std::normal_distribution<double> n(0.0, 1.0);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  VesselDeformation d;
  for (int i = 0; i < pull_count; ++i) {
    VesselDeformation::Pull p;
    p.branch = static_cast<int>(u(rng) * 3.0) % 3;
    p.position = 0.15 + 0.7 * u(rng);
    p.width = 0.15 + 0.2 * u(rng);
    p.amplitude_mm = amplitude_mm * Eigen::Vector2d(n(rng), n(rng));
    d.pulls.push_back(p);
  }
  for (int b = 0; b < 3; ++b) d.radius_scale[b] = std::max(0.6, 1.0 + radius_sd * n(rng));
  d.spread_scale = std::max(0.6, 1.0 + spread_sd * n(rng));
  return d;
}

TriangleMesh makeVesselPhantom(const VesselDeformation& deformation, const VesselPhantomOptions& o) {
  if (o.ring_vertices < 6 || !(o.ring_spacing_mm > 0.0)) {
    throw InvalidArgumentError("makeVesselPhantom: need >= 6 ring vertices and a positive ring spacing");
  }
  const int rv = o.ring_vertices;
  const double spread = o.branch_spread_mm * deformation.spread_scale;
  const double radii[3] = {o.cca_radius_mm, o.ica_radius_mm, o.eca_radius_mm};
  const double lengths[3] = {o.cca_length_mm, o.branch_length_mm, o.branch_length_mm};
  std::vector<Eigen::Vector3d> verts;
  std::vector<Eigen::Vector3i> faces;
  for (int b = 0; b < 3; ++b) {
    const int rings = ringCount(lengths[b], o.ring_spacing_mm);
    const int base = static_cast<int>(verts.size());
    auto centre = [&](double s) {
      Eigen::Vector3d c = centreLine(b, s, o, spread);
      for (const auto& p : deformation.pulls) {
        if (p.branch != b) continue;
        const double g = std::exp(-0.5 * std::pow((s - p.position) / p.width, 2));
        c.x() += g * p.amplitude_mm.x();
        c.y() += g * p.amplitude_mm.y();
      }
      return c;
    };
    for (int i = 0; i < rings; ++i) {
      const double s = static_cast<double>(i) / (rings - 1);
      const Eigen::Vector3d c = centre(s);
      const double h = 1e-3;
      const Eigen::Vector3d tangent = (centre(std::min(1.0, s + h)) - centre(std::max(0.0, s - h))).normalized();
      // Ring frame: e1 from x made perpendicular to the tangent, e2 = t x e1.
      Eigen::Vector3d e1 = Eigen::Vector3d::UnitX() - Eigen::Vector3d::UnitX().dot(tangent) * tangent;
      e1.normalize();
      const Eigen::Vector3d e2 = tangent.cross(e1);
      // Radius tapers a little along a branch (as real arteries).
      const double radius = radii[b] * deformation.radius_scale[b] * (1.0 - 0.08 * s);
      for (int j = 0; j < rv; ++j) {
        const double a = 2.0 * std::numbers::pi * j / rv;
        verts.push_back(c + radius * (std::cos(a) * e1 + std::sin(a) * e2));
      }
    }
    for (int i = 0; i + 1 < rings; ++i) {
      for (int j = 0; j < rv; ++j) {
        const int a = base + i * rv + j;
        const int b2 = base + i * rv + (j + 1) % rv;
        const int c = a + rv;
        const int d = b2 + rv;
        // Counter-clockwise seen from outside: the ring runs counter-clockwise about the tangent.
        faces.emplace_back(a, b2, d);
        faces.emplace_back(a, d, c);
      }
    }
  }
  TriangleMesh mesh;
  mesh.vertices.resize(static_cast<Eigen::Index>(verts.size()), 3);
  for (std::size_t i = 0; i < verts.size(); ++i) mesh.vertices.row(static_cast<Eigen::Index>(i)) = verts[i].transpose();
  mesh.faces.resize(static_cast<Eigen::Index>(faces.size()), 3);
  for (std::size_t i = 0; i < faces.size(); ++i) mesh.faces.row(static_cast<Eigen::Index>(i)) = faces[i].transpose();
  mesh.name = "carotid_phantom";
  mesh.frame = "Phantom";
  return mesh;
}

std::vector<int> phantomFiducialVertices(const VesselPhantomOptions& o) {
  const int rv = o.ring_vertices;
  const int cca = ringCount(o.cca_length_mm, o.ring_spacing_mm);
  const int br = ringCount(o.branch_length_mm, o.ring_spacing_mm);
  const int ica0 = cca * rv;
  const int eca0 = ica0 + br * rv;
  // Spread over the three branches, different sides of each tube.
  return {(cca / 4) * rv + 0,
          (cca / 2) * rv + rv / 4,
          (3 * cca / 4) * rv + rv / 2,
          ica0 + (br / 3) * rv + 0,
          ica0 + (2 * br / 3) * rv + rv / 2,
          eca0 + (br / 3) * rv + rv / 4,
          eca0 + (2 * br / 3) * rv + 3 * rv / 4};
}

}  // namespace mrsns::deformation
