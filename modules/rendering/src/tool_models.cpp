// Tool glyphs from analytic primitives (see tool_models.h for the frames).
#include "mrsns/rendering/tool_models.h"

#include <cmath>
#include <numbers>
#include <vector>

#include "mrsns/core/error.h"
#include "mrsns/core/mesh_ops.h"

namespace mrsns::rendering {
namespace {

struct MeshBuilder {
  std::vector<Eigen::Vector3d> vertices;
  std::vector<Eigen::Vector3i> faces;

  int add(const Eigen::Vector3d& p) {
    vertices.push_back(p);
    return static_cast<int>(vertices.size()) - 1;
  }
  void tri(int a, int b, int c) { faces.emplace_back(a, b, c); }

  TriangleMesh build(const std::string& frame = {}) const {
    TriangleMesh mesh;
    mesh.vertices.resize(static_cast<Eigen::Index>(vertices.size()), 3);
    for (std::size_t i = 0; i < vertices.size(); ++i) mesh.vertices.row(static_cast<Eigen::Index>(i)) = vertices[i];
    mesh.faces.resize(static_cast<Eigen::Index>(faces.size()), 3);
    for (std::size_t i = 0; i < faces.size(); ++i) mesh.faces.row(static_cast<Eigen::Index>(i)) = faces[i];
    mesh.frame = frame;
    mesh.normals = vertexNormals(mesh);
    return mesh;
  }
};

void checkSides(int sides) {
  if (sides < 3)
    throw InvalidArgumentError("sides = " + std::to_string(sides) + ": a round primitive needs >= 3 sides");
}

TriangleMesh merged(const std::vector<TriangleMesh>& parts, const std::string& frame) {
  TriangleMesh mesh = mergeMeshes(parts);
  mesh.frame = frame;
  mesh.normals = vertexNormals(mesh);
  return mesh;
}

}  // namespace

TriangleMesh coneMesh(const Eigen::Vector3d& a, const Eigen::Vector3d& b, double radius_a, double radius_b, int sides) {
  checkSides(sides);
  const double length = (b - a).norm();
  if (!(length > 0.0) || !std::isfinite(length)) {
    throw InvalidArgumentError("cone/cylinder: the two end points coincide or are not finite; give distinct ends");
  }
  if (!(radius_a >= 0.0) || !(radius_b >= 0.0) || (radius_a == 0.0 && radius_b == 0.0)) {
    throw InvalidArgumentError("cone/cylinder: radii must be >= 0 and not both 0");
  }
  const Eigen::Vector3d d = (b - a) / length;
  // u x v = d, so angles grow counter-clockwise about d and the side faces
  // below come out wound outwards.
  const Eigen::Vector3d u = d.unitOrthogonal();
  const Eigen::Vector3d v = d.cross(u);
  MeshBuilder m;
  auto ring = [&](const Eigen::Vector3d& c, double r) {
    std::vector<int> ids;
    if (r == 0.0) return std::vector<int>(static_cast<std::size_t>(sides), m.add(c));
    for (int i = 0; i < sides; ++i) {
      const double t = 2.0 * std::numbers::pi * i / sides;
      ids.push_back(m.add(c + r * (std::cos(t) * u + std::sin(t) * v)));
    }
    return ids;
  };
  const auto ra = ring(a, radius_a);
  const auto rb = ring(b, radius_b);
  for (int i = 0; i < sides; ++i) {
    const auto i0 = static_cast<std::size_t>(i);
    const auto i1 = static_cast<std::size_t>((i + 1) % sides);
    if (radius_a > 0.0) m.tri(ra[i0], ra[i1], rb[i1]);
    if (radius_b > 0.0) m.tri(ra[i0], rb[i1], rb[i0]);
  }
  if (radius_a > 0.0) {
    const int c = m.add(a);
    for (int i = 0; i < sides; ++i)
      m.tri(c, ra[static_cast<std::size_t>((i + 1) % sides)], ra[static_cast<std::size_t>(i)]);
  }
  if (radius_b > 0.0) {
    const int c = m.add(b);
    for (int i = 0; i < sides; ++i)
      m.tri(c, rb[static_cast<std::size_t>(i)], rb[static_cast<std::size_t>((i + 1) % sides)]);
  }
  return m.build();
}

TriangleMesh cylinderMesh(const Eigen::Vector3d& a, const Eigen::Vector3d& b, double radius, int sides) {
  if (!(radius > 0.0)) throw InvalidArgumentError("cylinder radius must be > 0 mm");
  return coneMesh(a, b, radius, radius, sides);
}

TriangleMesh boxMesh(const Eigen::Vector3d& lo, const Eigen::Vector3d& hi) {
  if (!((hi - lo).array() > 0.0).all()) throw InvalidArgumentError("box: every coordinate of hi must exceed lo");
  MeshBuilder m;
  for (int i = 0; i < 8; ++i) {
    m.add(Eigen::Vector3d((i & 1) ? hi.x() : lo.x(), (i & 2) ? hi.y() : lo.y(), (i & 4) ? hi.z() : lo.z()));
  }
  const int f[12][3] = {{0, 2, 3}, {0, 3, 1}, {4, 5, 7}, {4, 7, 6}, {0, 1, 5}, {0, 5, 4},
                        {2, 6, 7}, {2, 7, 3}, {0, 4, 6}, {0, 6, 2}, {1, 3, 7}, {1, 7, 5}};
  for (const auto& t : f) m.tri(t[0], t[1], t[2]);
  return m.build();
}

TriangleMesh sphereMesh(const Eigen::Vector3d& center, double radius, int slices, int stacks) {
  checkSides(slices);
  if (stacks < 2) throw InvalidArgumentError("sphere: stacks must be >= 2");
  if (!(radius > 0.0)) throw InvalidArgumentError("sphere radius must be > 0 mm");
  MeshBuilder m;
  const int top = m.add(center + Eigen::Vector3d(0, 0, radius));
  std::vector<std::vector<int>> rings;
  for (int k = 1; k < stacks; ++k) {
    const double phi = std::numbers::pi * k / stacks;
    std::vector<int> ring;
    for (int s = 0; s < slices; ++s) {
      const double theta = 2.0 * std::numbers::pi * s / slices;
      ring.push_back(m.add(center + radius * Eigen::Vector3d(std::sin(phi) * std::cos(theta),
                                                             std::sin(phi) * std::sin(theta), std::cos(phi))));
    }
    rings.push_back(ring);
  }
  const int bottom = m.add(center - Eigen::Vector3d(0, 0, radius));
  auto at = [&](std::size_t k, int s) { return rings[k][static_cast<std::size_t>(s % slices)]; };
  for (int s = 0; s < slices; ++s) m.tri(top, at(0, s), at(0, s + 1));
  for (std::size_t k = 0; k + 1 < rings.size(); ++k) {
    for (int s = 0; s < slices; ++s) {
      m.tri(at(k, s), at(k + 1, s), at(k + 1, s + 1));
      m.tri(at(k, s), at(k + 1, s + 1), at(k, s + 1));
    }
  }
  for (int s = 0; s < slices; ++s) m.tri(bottom, at(rings.size() - 1, s + 1), at(rings.size() - 1, s));
  return m.build();
}

TriangleMesh toolModel(ToolKind kind) {
  using V = Eigen::Vector3d;
  switch (kind) {
    case ToolKind::Stylus:
      return merged({coneMesh(V(0, 0, 0), V(0, 0, 10), 0.0, 1.0), cylinderMesh(V(0, 0, 10), V(0, 0, 100), 1.5),
                     cylinderMesh(V(0, 0, 100), V(0, 0, 150), 6.0), boxMesh(V(-30, -3, 138), V(30, 3, 144)),
                     boxMesh(V(-3, -30, 138), V(3, 30, 144)), sphereMesh(V(30, 0, 141), 5.0),
                     sphereMesh(V(-30, 0, 141), 5.0), sphereMesh(V(0, 30, 141), 5.0), sphereMesh(V(0, -30, 141), 5.0)},
                    "StylusTip");
    case ToolKind::Drill:
      return merged({coneMesh(V(0, 0, 0), V(0, 0, 3), 0.0, 1.75), cylinderMesh(V(0, 0, 3), V(0, 0, 60), 1.75),
                     coneMesh(V(0, 0, 60), V(0, 0, 75), 4.0, 10.0), cylinderMesh(V(0, 0, 75), V(0, 0, 160), 18.0, 24),
                     boxMesh(V(-8, 15, 100), V(8, 90, 125))},
                    "DrillTip");
    case ToolKind::EndEffector:
      return merged(
          {cylinderMesh(V(0, 0, 0), V(0, 0, 40), 6.0), boxMesh(V(-15, -15, 40), V(15, 15, 60)),
           cylinderMesh(V(0, 0, 60), V(0, 0, 75), 31.5, 32), cylinderMesh(V(0, 0, 75), V(0, 0, 170), 37.0, 32)},
          "EndEffectorTip");
  }
  throw InvalidArgumentError("unknown tool kind");
}

}  // namespace mrsns::rendering
