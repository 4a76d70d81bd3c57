#pragma once
// Synthetic meshes with analytic geometry for the geometry tests and
// benchmarks: all closed ones are wound counter-clockwise seen from outside.
#include <Eigen/Core>
#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <map>
#include <numbers>
#include <utility>
#include <vector>

#include "mrsns/core/mesh.h"

namespace mrsns::test {

namespace detail {
inline TriangleMesh fromLists(const std::vector<Eigen::Vector3d>& v, const std::vector<std::array<int, 3>>& f) {
  TriangleMesh mesh;
  mesh.vertices.resize(static_cast<Eigen::Index>(v.size()), 3);
  for (std::size_t i = 0; i < v.size(); ++i) mesh.vertices.row(static_cast<Eigen::Index>(i)) = v[i].transpose();
  mesh.faces.resize(static_cast<Eigen::Index>(f.size()), 3);
  for (std::size_t i = 0; i < f.size(); ++i) {
    for (int k = 0; k < 3; ++k) mesh.faces(static_cast<Eigen::Index>(i), k) = f[i][static_cast<std::size_t>(k)];
  }
  return mesh;
}
}  // namespace detail

/// Icosahedron subdivided `subdivisions` times (20 * 4^s faces), vertices on
/// the sphere of `radius` about `center`.
inline TriangleMesh icosphere(double radius, int subdivisions,
                              const Eigen::Vector3d& center = Eigen::Vector3d::Zero()) {
  const double t = (1.0 + std::sqrt(5.0)) / 2.0;
  std::vector<Eigen::Vector3d> v = {{-1, t, 0},  {1, t, 0},  {-1, -t, 0}, {1, -t, 0}, {0, -1, t},  {0, 1, t},
                                    {0, -1, -t}, {0, 1, -t}, {t, 0, -1},  {t, 0, 1},  {-t, 0, -1}, {-t, 0, 1}};
  for (auto& p : v) p.normalize();
  std::vector<std::array<int, 3>> f = {{0, 11, 5}, {0, 5, 1},  {0, 1, 7},   {0, 7, 10}, {0, 10, 11},
                                       {1, 5, 9},  {5, 11, 4}, {11, 10, 2}, {10, 7, 6}, {7, 1, 8},
                                       {3, 9, 4},  {3, 4, 2},  {3, 2, 6},   {3, 6, 8},  {3, 8, 9},
                                       {4, 9, 5},  {2, 4, 11}, {6, 2, 10},  {8, 6, 7},  {9, 8, 1}};
  for (int s = 0; s < subdivisions; ++s) {
    std::map<std::pair<int, int>, int> midpoint;
    auto mid = [&](int a, int b) {
      const auto key = std::minmax(a, b);
      const auto it = midpoint.find(key);
      if (it != midpoint.end()) return it->second;
      v.push_back((v[static_cast<std::size_t>(a)] + v[static_cast<std::size_t>(b)]).normalized());
      const int index = static_cast<int>(v.size()) - 1;
      midpoint.emplace(key, index);
      return index;
    };
    std::vector<std::array<int, 3>> next;
    next.reserve(f.size() * 4);
    for (const auto& tri : f) {
      const int a = mid(tri[0], tri[1]);
      const int b = mid(tri[1], tri[2]);
      const int c = mid(tri[2], tri[0]);
      next.push_back({tri[0], a, c});
      next.push_back({tri[1], b, a});
      next.push_back({tri[2], c, b});
      next.push_back({a, b, c});
    }
    f = std::move(next);
  }
  for (auto& p : v) p = center + radius * p;
  TriangleMesh mesh = detail::fromLists(v, f);
  mesh.name = "icosphere";
  return mesh;
}

/// Axis-aligned box [lo, lo + size] with each face split into n x n quads
/// (two triangles each), vertices shared along the edges.
inline TriangleMesh box(const Eigen::Vector3d& size, int n = 1, const Eigen::Vector3d& lo = Eigen::Vector3d::Zero()) {
  std::map<std::array<int, 3>, int> index_of;
  std::vector<Eigen::Vector3d> v;
  std::vector<std::array<int, 3>> f;
  auto vertexAt = [&](const std::array<int, 3>& lattice) {
    const auto it = index_of.find(lattice);
    if (it != index_of.end()) return it->second;
    Eigen::Vector3d p;
    for (int k = 0; k < 3; ++k) p[k] = lo[k] + size[k] * lattice[static_cast<std::size_t>(k)] / n;
    v.push_back(p);
    const int index = static_cast<int>(v.size()) - 1;
    index_of.emplace(lattice, index);
    return index;
  };
  for (int axis = 0; axis < 3; ++axis) {
    for (const int side : {0, n}) {
      // e_u x e_v points along +axis; swap on the low side so normals face out.
      int u = (axis + 1) % 3;
      int w = (axis + 2) % 3;
      if (side == 0) std::swap(u, w);
      for (int i = 0; i < n; ++i) {
        for (int j = 0; j < n; ++j) {
          auto at = [&](int di, int dj) {
            std::array<int, 3> l{};
            l[static_cast<std::size_t>(axis)] = side;
            l[static_cast<std::size_t>(u)] = i + di;
            l[static_cast<std::size_t>(w)] = j + dj;
            return vertexAt(l);
          };
          f.push_back({at(0, 0), at(1, 0), at(1, 1)});
          f.push_back({at(0, 0), at(1, 1), at(0, 1)});
        }
      }
    }
  }
  TriangleMesh mesh = detail::fromLists(v, f);
  mesh.name = "box";
  return mesh;
}

/// Cylinder of `radius` about the z axis from z = -height/2 to +height/2:
/// `segments` around, `rings` + 1 rings of vertices (the first at angle 0),
/// with fan caps when `capped`.
inline TriangleMesh cylinder(double radius, double height, int segments, int rings, bool capped) {
  std::vector<Eigen::Vector3d> v;
  std::vector<std::array<int, 3>> f;
  for (int r = 0; r <= rings; ++r) {
    const double z = -height / 2 + height * r / rings;
    for (int s = 0; s < segments; ++s) {
      const double angle = 2.0 * std::numbers::pi * s / segments;
      v.emplace_back(radius * std::cos(angle), radius * std::sin(angle), z);
    }
  }
  auto at = [&](int r, int s) { return r * segments + (s % segments); };
  for (int r = 0; r < rings; ++r) {
    for (int s = 0; s < segments; ++s) {
      f.push_back({at(r, s), at(r, s + 1), at(r + 1, s + 1)});
      f.push_back({at(r, s), at(r + 1, s + 1), at(r + 1, s)});
    }
  }
  if (capped) {
    v.emplace_back(0.0, 0.0, -height / 2);
    const int bottom = static_cast<int>(v.size()) - 1;
    v.emplace_back(0.0, 0.0, height / 2);
    const int top = static_cast<int>(v.size()) - 1;
    for (int s = 0; s < segments; ++s) {
      f.push_back({bottom, at(0, s + 1), at(0, s)});
      f.push_back({top, at(rings, s), at(rings, s + 1)});
    }
  }
  TriangleMesh mesh = detail::fromLists(v, f);
  mesh.name = capped ? "cylinder" : "tube";
  return mesh;
}

/// Square grid in the plane z = 0 spanning [0, size]^2, n x n quads, normals +z.
inline TriangleMesh planeGrid(double size, int n) {
  std::vector<Eigen::Vector3d> v;
  std::vector<std::array<int, 3>> f;
  for (int j = 0; j <= n; ++j) {
    for (int i = 0; i <= n; ++i) v.emplace_back(size * i / n, size * j / n, 0.0);
  }
  auto at = [&](int i, int j) { return j * (n + 1) + i; };
  for (int j = 0; j < n; ++j) {
    for (int i = 0; i < n; ++i) {
      f.push_back({at(i, j), at(i + 1, j), at(i + 1, j + 1)});
      f.push_back({at(i, j), at(i + 1, j + 1), at(i, j + 1)});
    }
  }
  TriangleMesh mesh = detail::fromLists(v, f);
  mesh.name = "plane";
  return mesh;
}

/// Smallest distance from `center` to the plane of any face: the polyhedron
/// (if convex and containing `center`) contains the ball of this radius.
inline double inradius(const TriangleMesh& mesh, const Eigen::Vector3d& center = Eigen::Vector3d::Zero()) {
  double r = std::numeric_limits<double>::infinity();
  for (Eigen::Index i = 0; i < mesh.faceCount(); ++i) {
    const Eigen::Vector3d a = mesh.vertices.row(mesh.faces(i, 0)).transpose();
    const Eigen::Vector3d b = mesh.vertices.row(mesh.faces(i, 1)).transpose();
    const Eigen::Vector3d c = mesh.vertices.row(mesh.faces(i, 2)).transpose();
    const Eigen::Vector3d n = (b - a).cross(c - a).normalized();
    r = std::min(r, std::abs(n.dot(a - center)));
  }
  return r;
}

}  // namespace mrsns::test
