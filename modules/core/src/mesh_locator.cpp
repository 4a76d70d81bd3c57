#include "mrsns/core/mesh_locator.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <string>
#include <utility>

#include "mrsns/core/error.h"
#include "mrsns/core/parallel.h"

namespace mrsns {
namespace {

// Closest point on segment a-b; t receives the fraction along it.
Eigen::Vector3d closestOnSegment(const Eigen::Vector3d& p, const Eigen::Vector3d& a, const Eigen::Vector3d& b,
                                 double& t) {
  const Eigen::Vector3d ab = b - a;
  const double len2 = ab.squaredNorm();
  t = len2 > 0.0 ? std::clamp((p - a).dot(ab) / len2, 0.0, 1.0) : 0.0;
  return a + t * ab;
}

// A zero-area triangle has no interior region: its closest point lies on one
// of its three edges.
Eigen::Vector3d closestOnDegenerateTriangle(const Eigen::Vector3d& p, const Eigen::Vector3d& a,
                                            const Eigen::Vector3d& b, const Eigen::Vector3d& c, Eigen::Vector3d& bary) {
  double t = 0.0;
  Eigen::Vector3d best = closestOnSegment(p, a, b, t);
  bary = {1.0 - t, t, 0.0};
  double best_d = (p - best).squaredNorm();
  Eigen::Vector3d q = closestOnSegment(p, b, c, t);
  if ((p - q).squaredNorm() < best_d) {
    best = q;
    best_d = (p - q).squaredNorm();
    bary = {0.0, 1.0 - t, t};
  }
  q = closestOnSegment(p, c, a, t);
  if ((p - q).squaredNorm() < best_d) {
    best = q;
    bary = {t, 0.0, 1.0 - t};
  }
  return best;
}

double boxDistanceSquared(const Eigen::Vector3d& p, const Eigen::Vector3d& lo, const Eigen::Vector3d& hi) {
  const Eigen::Vector3d d = (lo - p).cwiseMax(p - hi).cwiseMax(0.0);
  return d.squaredNorm();
}

// Squared distance from p to the box `which` (0, 1) of a node's child boxes,
// in double from the float bounds (which enclose the true ones), so it never
// exceeds the distance to the true box: pruning with it stays exact.
[[gnu::always_inline]] inline double childBoxDistanceSquared(const double p[3], const float lo[3], const float hi[3]) {
  double s = 0.0;
  for (int k = 0; k < 3; ++k) {
    const double below = static_cast<double>(lo[k]) - p[k];
    const double above = p[k] - static_cast<double>(hi[k]);
    const double d = below > above ? below : above;
    s += d > 0.0 ? d * d : 0.0;
  }
  return s;
}

float floatBelow(double x) {
  float f = static_cast<float>(x);
  if (static_cast<double>(f) > x) f = std::nextafter(f, -std::numeric_limits<float>::infinity());
  return f;
}

float floatAbove(double x) {
  float f = static_cast<float>(x);
  if (static_cast<double>(f) < x) f = std::nextafter(f, std::numeric_limits<float>::infinity());
  return f;
}

// Slab test of the line o + t d, t in [t0, t1], against a box.
bool lineHitsBox(const Eigen::Vector3d& o, const Eigen::Vector3d& d, const Eigen::Vector3d& inv_d, double t0, double t1,
                 const Eigen::Vector3d& lo, const Eigen::Vector3d& hi) {
  for (int i = 0; i < 3; ++i) {
    if (d[i] == 0.0) {
      if (o[i] < lo[i] || o[i] > hi[i]) return false;
      continue;
    }
    double ta = (lo[i] - o[i]) * inv_d[i];
    double tb = (hi[i] - o[i]) * inv_d[i];
    if (ta > tb) std::swap(ta, tb);
    t0 = std::max(t0, ta);
    t1 = std::min(t1, tb);
    if (t0 > t1) return false;
  }
  return true;
}

double angleBetween(const Eigen::Vector3d& u, const Eigen::Vector3d& v) {
  return std::atan2(u.cross(v).norm(), u.dot(v));
}

}  // namespace

namespace {

// Ericson's routine, inlined into the BVH search (a call per face costs as
// much as the arithmetic).
[[gnu::always_inline]] inline Eigen::Vector3d closestOnTriangle(const Eigen::Vector3d& p, const Eigen::Vector3d& a,
                                                               const Eigen::Vector3d& b, const Eigen::Vector3d& c,
                                                               Eigen::Vector3d& bary) {
  const Eigen::Vector3d ab = b - a;
  const Eigen::Vector3d ac = c - a;
  const Eigen::Vector3d ap = p - a;
  const double d1 = ab.dot(ap);
  const double d2 = ac.dot(ap);
  if (d1 <= 0.0 && d2 <= 0.0) {
    bary = {1.0, 0.0, 0.0};
    return a;
  }
  const Eigen::Vector3d bp = p - b;
  const double d3 = ab.dot(bp);
  const double d4 = ac.dot(bp);
  if (d3 >= 0.0 && d4 <= d3) {
    bary = {0.0, 1.0, 0.0};
    return b;
  }
  const double vc = d1 * d4 - d3 * d2;
  if (vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0) {
    const double v = d1 / (d1 - d3);
    bary = {1.0 - v, v, 0.0};
    return a + v * ab;
  }
  const Eigen::Vector3d cp = p - c;
  const double d5 = ab.dot(cp);
  const double d6 = ac.dot(cp);
  if (d6 >= 0.0 && d5 <= d6) {
    bary = {0.0, 0.0, 1.0};
    return c;
  }
  const double vb = d5 * d2 - d1 * d6;
  if (vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0) {
    const double w = d2 / (d2 - d6);
    bary = {1.0 - w, 0.0, w};
    return a + w * ac;
  }
  const double va = d3 * d6 - d5 * d4;
  if (va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0) {
    const double w = (d4 - d3) / ((d4 - d3) + (d5 - d6));
    bary = {0.0, 1.0 - w, w};
    return b + w * (c - b);
  }
  const double sum = va + vb + vc;
  if (!(sum > 0.0)) return closestOnDegenerateTriangle(p, a, b, c, bary);
  const double v = vb / sum;
  const double w = vc / sum;
  bary = {1.0 - v - w, v, w};
  return a + v * ab + w * ac;
}

}  // namespace

Eigen::Vector3d closestPointOnTriangle(const Eigen::Vector3d& p, const Eigen::Vector3d& a, const Eigen::Vector3d& b,
                                       const Eigen::Vector3d& c, Eigen::Vector3d* barycentric) {
  Eigen::Vector3d bary_storage;
  return closestOnTriangle(p, a, b, c, barycentric != nullptr ? *barycentric : bary_storage);
}

MeshLocator::MeshLocator(const TriangleMesh& mesh, const MeshLocatorOptions& options)
    : vertices_(mesh.vertices), faces_(mesh.faces) {
  const std::string what = mesh.name.empty() ? std::string("MeshLocator mesh") : "MeshLocator mesh '" + mesh.name + "'";
  validateMesh(mesh, what);
  if (mesh.faceCount() == 0) {
    throw InvalidArgumentError(what + ": has no faces; a surface query needs a triangle mesh");
  }
  if (options.max_leaf_faces < 1) {
    throw InvalidArgumentError("MeshLocatorOptions::max_leaf_faces must be >= 1 (got " +
                               std::to_string(options.max_leaf_faces) + ")");
  }
  face_normals_ = mrsns::faceNormals(mesh);
  scale_ = std::max(boundingBox(mesh).diagonal().norm(), 1e-300);
  build(options);
}

const MeshLocator::Topology& MeshLocator::topology() const {
  std::call_once(topology_->once, [this] {
    TriangleMesh mesh;
    mesh.vertices = vertices_;
    mesh.faces = faces_;
    topology_->closed = isClosed(mesh);
    computePseudoNormals(*topology_);
  });
  return *topology_;
}

void MeshLocator::build(const MeshLocatorOptions& options) {
  const Eigen::Index m = faces_.rows();
  // The split permutes these small records in place, so each level of the
  // build streams through contiguous memory.
  struct Item {
    Eigen::Vector3d centroid;
    std::int32_t face;
  };
  std::vector<Item> items(static_cast<std::size_t>(m));
  for (Eigen::Index f = 0; f < m; ++f) {
    items[static_cast<std::size_t>(f)] = {
        (vertices_.row(faces_(f, 0)) + vertices_.row(faces_(f, 1)) + vertices_.row(faces_(f, 2))).transpose() / 3.0,
        static_cast<std::int32_t>(f)};
  }
  // Median split on the longest axis of the centroid bounds: O(M log M), a
  // balanced tree of depth log2(M), and good enough for closest-point queries.
  // `split` divides items [begin, end) of a node of `out` between two new
  // children and gives their ranges, or makes the node a leaf (false).
  struct Task {
    std::int32_t node, begin, end;
  };
  const int max_leaf = options.max_leaf_faces;
  auto split = [&items, max_leaf](const Task& task, std::vector<Node>& out, std::array<Task, 2>& children) {
    const std::int32_t count = task.end - task.begin;
    if (count <= max_leaf) {
      out[static_cast<std::size_t>(task.node)].first = task.begin;
      out[static_cast<std::size_t>(task.node)].count = count;
      return false;
    }
    Eigen::Vector3d clo = Eigen::Vector3d::Constant(std::numeric_limits<double>::infinity());
    Eigen::Vector3d chi = -clo;
    for (std::int32_t i = task.begin; i < task.end; ++i) {
      const Eigen::Vector3d& c = items[static_cast<std::size_t>(i)].centroid;
      clo = clo.cwiseMin(c);
      chi = chi.cwiseMax(c);
    }
    int axis = 0;
    (chi - clo).maxCoeff(&axis);
    const std::int32_t mid = task.begin + count / 2;
    std::nth_element(items.begin() + task.begin, items.begin() + mid, items.begin() + task.end,
                     [axis](const Item& x, const Item& y) { return x.centroid[axis] < y.centroid[axis]; });
    const auto left = static_cast<std::int32_t>(out.size());
    out[static_cast<std::size_t>(task.node)].left = left;
    out[static_cast<std::size_t>(task.node)].right = left + 1;
    out.push_back({});
    out.push_back({});
    children = {Task{left, task.begin, mid}, Task{left + 1, mid, task.end}};
    return true;
  };
  // The top levels are split here until there is a subtree per thread; the
  // subtrees (disjoint ranges of items) are then built concurrently, each
  // into its own node list, and appended. The tree is the same for any
  // thread count: only where its nodes are stored differs.
  nodes_.clear();
  nodes_.reserve(static_cast<std::size_t>(2 * m / max_leaf + 2));
  nodes_.push_back({});
  std::vector<Task> subtrees{{0, 0, static_cast<std::int32_t>(m)}};
  const std::size_t threads = m >= 8192 ? std::min<std::size_t>(defaultThreadCount(), 8) : 1;
  while (subtrees.size() < threads) {
    std::vector<Task> next;
    for (const Task& task : subtrees) {
      std::array<Task, 2> children{};
      if (split(task, nodes_, children)) next.insert(next.end(), children.begin(), children.end());
    }
    subtrees = std::move(next);
    if (subtrees.empty()) break;  // all leaves already
  }
  std::vector<std::vector<Node>> built(subtrees.size());
  parallelForBlocks(
      0, subtrees.size(),
      [&](std::size_t first, std::size_t last) {
        for (std::size_t k = first; k < last; ++k) {
          std::vector<Node>& out = built[k];
          const std::int32_t count = subtrees[k].end - subtrees[k].begin;
          out.reserve(static_cast<std::size_t>(2 * count / max_leaf + 2));
          out.push_back({});
          std::vector<Task> tasks{{0, subtrees[k].begin, subtrees[k].end}};
          while (!tasks.empty()) {
            const Task task = tasks.back();
            tasks.pop_back();
            std::array<Task, 2> children{};
            if (split(task, out, children)) tasks.insert(tasks.end(), children.begin(), children.end());
          }
        }
      },
      static_cast<unsigned>(subtrees.size()));
  // Corners copied in leaf order: a leaf's triangles then sit in one or two
  // cache lines instead of behind two indirections.
  order_.resize(items.size());
  triangles_.resize(items.size());
  parallelForBlocks(
      0, items.size(),
      [&](std::size_t first, std::size_t last) {
        for (std::size_t i = first; i < last; ++i) {
          order_[i] = items[i].face;
          for (int k = 0; k < 3; ++k) {
            triangles_[i][static_cast<std::size_t>(k)] = vertices_.row(faces_(order_[i], k)).transpose();
          }
        }
      },
      0, 16384);
  // Bounds bottom-up (children always come after their parent): each
  // subtree's concurrently, then the top levels'.
  auto bound = [this](std::vector<Node>& nodes, std::size_t from, std::size_t to) { boundNodes(nodes, from, to); };
  parallelForBlocks(
      0, subtrees.size(),
      [&](std::size_t first, std::size_t last) {
        for (std::size_t k = first; k < last; ++k) bound(built[k], 0, built[k].size());
      },
      static_cast<unsigned>(subtrees.size()));
  const std::size_t top_count = nodes_.size();
  for (std::size_t k = 0; k < subtrees.size(); ++k) {
    // Local node 0 is the subtree's root, already in nodes_; the others follow.
    const auto base = static_cast<std::int32_t>(nodes_.size());
    auto global = [&](std::int32_t local) { return local == 0 ? subtrees[k].node : base + local - 1; };
    for (std::size_t i = 0; i < built[k].size(); ++i) {
      Node node = built[k][i];
      if (node.count == 0) {
        node.left = global(node.left);
        node.right = global(node.right);
      }
      if (i == 0) {
        nodes_[static_cast<std::size_t>(subtrees[k].node)] = node;
      } else {
        nodes_.push_back(node);
      }
    }
  }
  // The top levels: inner nodes over the subtrees' roots (or, for a tree
  // split at the top into leaves only, those leaves). A subtree's root sits
  // among them and is bounded already; bounding it again gives the same box.
  bound(nodes_, 0, top_count);
  buildSearchNodes();
}

void MeshLocator::boundNodes(std::vector<Node>& nodes, std::size_t from, std::size_t to) const {
  for (auto n = to; n-- > from;) {
    Node& node = nodes[n];
    if (node.count > 0) {
      node.lo = node.hi = triangles_[static_cast<std::size_t>(node.first)][0];
      for (std::int32_t i = node.first; i < node.first + node.count; ++i) {
        for (const Eigen::Vector3d& corner : triangles_[static_cast<std::size_t>(i)]) {
          node.lo = node.lo.cwiseMin(corner);
          node.hi = node.hi.cwiseMax(corner);
        }
      }
    } else {
      const Node& l = nodes[static_cast<std::size_t>(node.left)];
      const Node& r = nodes[static_cast<std::size_t>(node.right)];
      node.lo = l.lo.cwiseMin(r.lo);
      node.hi = l.hi.cwiseMax(r.hi);
    }
  }
}

void MeshLocator::buildSearchNodes() {
  // The closest-point search walks a compact copy of the inner nodes: each
  // 64-byte record (one cache line) holds both children's boxes, in float
  // rounded outwards, and where they are, so a step down the tree touches
  // one line instead of two 64-byte nodes. The search is memory-bound.
  std::vector<std::int32_t> compact_index(nodes_.size(), -1);
  std::int32_t inner = 0;
  for (std::size_t n = 0; n < nodes_.size(); ++n) {
    if (nodes_[n].count == 0) compact_index[n] = inner++;
  }
  search_nodes_.assign(static_cast<std::size_t>(inner), SearchNode{});
  for (std::size_t n = 0; n < nodes_.size(); ++n) {
    const Node& node = nodes_[n];
    if (node.count > 0) continue;
    SearchNode& out = search_nodes_[static_cast<std::size_t>(compact_index[n])];
    for (int c = 0; c < 2; ++c) {
      const Node& child = nodes_[static_cast<std::size_t>(c == 0 ? node.left : node.right)];
      for (int k = 0; k < 3; ++k) {
        out.lo[c][k] = floatBelow(child.lo[k]);
        out.hi[c][k] = floatAbove(child.hi[k]);
      }
      out.first[c] = child.count > 0 ? child.first : compact_index[static_cast<std::size_t>(c == 0 ? node.left : node.right)];
      out.count[c] = child.count;
    }
  }
}

MeshLocator MeshLocator::refitted(const PointsN3& vertices) const {
  if (vertices.rows() != vertices_.rows()) {
    throw InvalidArgumentError("MeshLocator::refitted: " + std::to_string(vertices.rows()) + " vertices for a mesh of " +
                               std::to_string(vertices_.rows()));
  }
  if (!vertices.allFinite()) throw InvalidArgumentError("MeshLocator::refitted: a vertex is not finite");
  MeshLocator out = *this;
  out.vertices_ = vertices;
  out.topology_ = std::make_shared<Topology>();  // pseudo-normals of the new shape, on first use
  TriangleMesh mesh;
  mesh.vertices = vertices;
  mesh.faces = faces_.cast<int>();
  out.face_normals_ = mrsns::faceNormals(mesh);
  out.scale_ = std::max(boundingBox(mesh).diagonal().norm(), 1e-300);
  for (std::size_t i = 0; i < out.order_.size(); ++i) {
    for (int k = 0; k < 3; ++k) {
      out.triangles_[i][static_cast<std::size_t>(k)] = vertices.row(faces_(out.order_[i], k)).transpose();
    }
  }
  // The same tree over the moved faces: every box recomputed bottom-up (children come after their parent).
  out.boundNodes(out.nodes_, 0, out.nodes_.size());
  out.buildSearchNodes();
  return out;
}

void MeshLocator::computePseudoNormals(Topology& t) const {
  const Eigen::Index m = faces_.rows();
  t.vertex_pseudo_normals = PointsN3::Zero(vertices_.rows(), 3);
  for (Eigen::Index f = 0; f < m; ++f) {
    const Eigen::RowVector3d n = face_normals_.row(f);
    for (int k = 0; k < 3; ++k) {
      const Eigen::Vector3d p = vertices_.row(faces_(f, k)).transpose();
      const Eigen::Vector3d u = vertices_.row(faces_(f, (k + 1) % 3)).transpose() - p;
      const Eigen::Vector3d v = vertices_.row(faces_(f, (k + 2) % 3)).transpose() - p;
      t.vertex_pseudo_normals.row(faces_(f, k)) += angleBetween(u, v) * n;
    }
  }
  // Edge pseudo-normal: the sum of the normals of the faces sharing the edge,
  // found through half-edges bucketed by start vertex (CSR; no sort or hash).
  const auto nv = static_cast<std::size_t>(vertices_.rows());
  const std::size_t slots = static_cast<std::size_t>(3 * m);
  auto head = [&](std::size_t slot) { return static_cast<std::size_t>(faces_(slot / 3, slot % 3)); };
  auto tail = [&](std::size_t slot) { return static_cast<std::size_t>(faces_(slot / 3, (slot % 3 + 1) % 3)); };
  std::vector<std::size_t> start(nv + 1, 0);
  for (std::size_t slot = 0; slot < slots; ++slot) ++start[head(slot) + 1];
  for (std::size_t v = 0; v < nv; ++v) start[v + 1] += start[v];
  std::vector<std::size_t> fill(start.begin(), start.end() - 1);
  std::vector<std::size_t> by_head(slots);
  for (std::size_t slot = 0; slot < slots; ++slot) by_head[fill[head(slot)]++] = slot;
  t.edge_pseudo_normals.assign(slots, Eigen::Vector3d::Zero());
  for (std::size_t slot = 0; slot < slots; ++slot) {
    const std::size_t a = head(slot);
    const std::size_t b = tail(slot);
    Eigen::Vector3d sum = Eigen::Vector3d::Zero();
    for (std::size_t i = start[a]; i < start[a + 1]; ++i) {
      if (tail(by_head[i]) == b) sum += face_normals_.row(static_cast<Eigen::Index>(by_head[i] / 3)).transpose();
    }
    for (std::size_t i = start[b]; i < start[b + 1]; ++i) {
      if (tail(by_head[i]) == a) sum += face_normals_.row(static_cast<Eigen::Index>(by_head[i] / 3)).transpose();
    }
    t.edge_pseudo_normals[slot] = sum;
  }
}

inline void MeshLocator::testFace(const Eigen::Vector3d& query, Eigen::Index slot, SurfacePoint& best) const {
  const auto& tri = triangles_[static_cast<std::size_t>(slot)];
  Eigen::Vector3d bary;
  const Eigen::Vector3d p = closestOnTriangle(query, tri[0], tri[1], tri[2], bary);
  const double d2 = (p - query).squaredNorm();
  // best.distance holds the squared distance during the search.
  if (d2 < best.distance) {
    best.distance = d2;
    best.point = p;
    best.face = order_[static_cast<std::size_t>(slot)];
    best.barycentric = bary;
  }
}

SurfacePoint MeshLocator::closestPoint(const Eigen::Vector3d& query) const {
  return closestPointWithin(query, std::numeric_limits<double>::infinity());
}

SurfacePoint MeshLocator::closestPointWithin(const Eigen::Vector3d& query, double max_distance) const {
  if (!query.allFinite()) {
    throw InvalidArgumentError("MeshLocator::closestPoint: the query point is not finite; pass a point without NaN");
  }
  if (std::isnan(max_distance) || max_distance < 0.0) {
    throw InvalidArgumentError("MeshLocator::closestPointWithin: max_distance must be >= 0 (got " +
                               std::to_string(max_distance) + ")");
  }
  SurfacePoint best;
  // Start from the bound, nudged up so a point exactly at max_distance is kept.
  best.distance = std::nextafter(max_distance * max_distance, std::numeric_limits<double>::infinity());
  const double q[3] = {query.x(), query.y(), query.z()};
  auto testLeaf = [&](std::int32_t first, std::int32_t count) {
    for (std::int32_t i = first; i < first + count; ++i) testFace(query, i, best);
  };
  if (search_nodes_.empty()) {  // the whole tree is one leaf
    if (boxDistanceSquared(query, nodes_[0].lo, nodes_[0].hi) < best.distance) testLeaf(nodes_[0].first, nodes_[0].count);
  } else if (boxDistanceSquared(query, nodes_[0].lo, nodes_[0].hi) < best.distance) {
    // Depth-first, nearer child first; an entry is (leaf count or 0, index,
    // squared distance to its box). The tree depth is at most ~log2(M) + 1,
    // and each level leaves at most one pending sibling on the stack.
    struct Pending {
      std::int32_t index;
      std::int32_t count;  // > 0: a leaf (faces index .. index + count); 0: a search node
      double bound;
    };
    std::array<Pending, 128> stack;
    int top = 0;
    stack[top++] = {0, 0, 0.0};
    while (top > 0) {
      const Pending item = stack[--top];
      if (item.bound >= best.distance) continue;
      if (item.count > 0) {
        testLeaf(item.index, item.count);
        continue;
      }
      const SearchNode& node = search_nodes_[static_cast<std::size_t>(item.index)];
      const double d0 = childBoxDistanceSquared(q, node.lo[0], node.hi[0]);
      const double d1 = childBoxDistanceSquared(q, node.lo[1], node.hi[1]);
      const int near = d1 < d0 ? 1 : 0;
      const int far = 1 - near;
      const double dn = near == 0 ? d0 : d1;
      const double df = near == 0 ? d1 : d0;
      if (df < best.distance) stack[top++] = {node.first[far], node.count[far], df};
      if (dn < best.distance) {
        if (node.count[near] > 0) {
          testLeaf(node.first[near], node.count[near]);  // no need to push what is tested now
        } else {
          stack[top++] = {node.first[near], 0, dn};
        }
      }
    }
  }
  if (best.face < 0) return SurfacePoint{};
  best.distance = std::sqrt(best.distance);
  return best;
}

SurfacePoint MeshLocator::closestPointBruteForce(const Eigen::Vector3d& query) const {
  SurfacePoint best;
  for (Eigen::Index slot = 0; slot < faces_.rows(); ++slot) testFace(query, slot, best);
  best.distance = std::sqrt(best.distance);
  return best;
}

SignedSurfacePoint MeshLocator::signedClosestPoint(const Eigen::Vector3d& query, bool allow_open) const {
  const Topology& topology = this->topology();
  if (!topology.closed && !allow_open) {
    throw ComputationError(
        "MeshLocator::signedClosestPoint: the mesh is not closed (some edge is not shared by exactly two "
        "consistently oriented faces), so inside/outside is undefined; close the mesh or pass allow_open");
  }
  SignedSurfacePoint result;
  static_cast<SurfacePoint&>(result) = closestPoint(query);
  const Eigen::Index f = result.face;
  const Eigen::Vector3d& w = result.barycentric;
  // Ericson's routine returns exact zeros on edge and vertex regions, which
  // tells which feature (face, edge, vertex) holds the closest point.
  const int zeros = (w[0] == 0.0) + (w[1] == 0.0) + (w[2] == 0.0);
  Eigen::Vector3d normal;
  if (zeros == 0) {
    normal = face_normals_.row(f).transpose();
  } else if (zeros == 1) {
    int z = 0;
    while (w[z] != 0.0) ++z;
    normal = topology.edge_pseudo_normals[static_cast<std::size_t>(3 * f + (z + 1) % 3)];
  } else {
    int k = 0;
    while (w[k] == 0.0) ++k;
    normal = topology.vertex_pseudo_normals.row(faces_(f, k)).transpose();
  }
  const double side = (query - result.point).dot(normal);
  result.signed_distance = side < 0.0 ? -result.distance : result.distance;
  return result;
}

std::vector<RayHit> MeshLocator::intersectLine(const Eigen::Vector3d& origin, const Eigen::Vector3d& direction,
                                               double t_min, double t_max) const {
  if (!origin.allFinite() || !direction.allFinite() || !(direction.squaredNorm() > 0.0)) {
    throw InvalidArgumentError(
        "MeshLocator::intersectLine: origin and direction must be finite and the direction non-zero");
  }
  if (std::isnan(t_min) || std::isnan(t_max)) {
    throw InvalidArgumentError("MeshLocator::intersectLine: t_min/t_max must not be NaN");
  }
  const double dir_norm = direction.norm();
  // Hits on shared edges are found by both faces; accept barycentric
  // coordinates a hair outside [0, 1] so none slips between, then merge.
  constexpr double kBaryTolerance = 1e-12;
  const double t_tolerance = 1e-9 * scale_ / dir_norm;
  const Eigen::Vector3d inv_d = direction.cwiseInverse();
  const Eigen::Vector3d pad = Eigen::Vector3d::Constant(1e-9 * scale_);

  std::vector<RayHit> hits;
  std::array<std::int32_t, 128> stack{};
  int top = 0;
  stack[top++] = 0;
  while (top > 0) {
    const Node& node = nodes_[static_cast<std::size_t>(stack[--top])];
    if (!lineHitsBox(origin, direction, inv_d, t_min - t_tolerance, t_max + t_tolerance, node.lo - pad,
                     node.hi + pad)) {
      continue;
    }
    if (node.count == 0) {
      stack[top++] = node.left;
      stack[top++] = node.right;
      continue;
    }
    for (std::int32_t i = node.first; i < node.first + node.count; ++i) {
      const std::int32_t f = order_[static_cast<std::size_t>(i)];
      // Moller-Trumbore.
      const auto& tri = triangles_[static_cast<std::size_t>(i)];
      const Eigen::Vector3d& a = tri[0];
      const Eigen::Vector3d e1 = tri[1] - a;
      const Eigen::Vector3d e2 = tri[2] - a;
      const Eigen::Vector3d pvec = direction.cross(e2);
      const double det = e1.dot(pvec);
      // Parallel (or degenerate) faces: a line in the face's plane has no single crossing.
      if (std::abs(det) <= 1e-14 * e1.norm() * e2.norm() * dir_norm) continue;
      const double inv_det = 1.0 / det;
      const Eigen::Vector3d tvec = origin - a;
      const double u = tvec.dot(pvec) * inv_det;
      if (u < -kBaryTolerance || u > 1.0 + kBaryTolerance) continue;
      const Eigen::Vector3d qvec = tvec.cross(e1);
      const double v = direction.dot(qvec) * inv_det;
      if (v < -kBaryTolerance || u + v > 1.0 + kBaryTolerance) continue;
      const double t = e2.dot(qvec) * inv_det;
      if (t < t_min || t > t_max) continue;
      RayHit hit;
      hit.t = t;
      hit.point = origin + t * direction;
      hit.face = f;
      hit.barycentric = {1.0 - u - v, u, v};
      hit.entering = det > 0.0;  // det = -d . (e1 x e2)
      hits.push_back(hit);
    }
  }
  std::sort(hits.begin(), hits.end(), [](const RayHit& x, const RayHit& y) { return x.t < y.t; });
  // Merge duplicates from shared edges/vertices: within a cluster of equal t
  // keep one entering and one leaving hit (a tangent touch keeps both).
  std::vector<RayHit> merged;
  merged.reserve(hits.size());
  for (std::size_t i = 0; i < hits.size();) {
    std::size_t j = i;
    bool have_in = false;
    bool have_out = false;
    for (; j < hits.size() && hits[j].t - hits[i].t <= t_tolerance; ++j) {
      bool& have = hits[j].entering ? have_in : have_out;
      if (!have) merged.push_back(hits[j]);
      have = true;
    }
    i = j;
  }
  return merged;
}

}  // namespace mrsns
