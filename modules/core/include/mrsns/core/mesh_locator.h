#pragma once
// Closest point on a triangle surface, signed distance and line/ray-mesh
// intersection, accelerated by a bounding-volume hierarchy over the faces.
#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <limits>
#include <memory>
#include <mutex>
#include <vector>

#include "mrsns/core/mesh.h"
#include "mrsns/core/mesh_ops.h"

namespace mrsns {

/// Closest point of a triangle to `p` (Ericson, Real-Time Collision
/// Detection 5.1.5). Returns the point; `barycentric` receives the weights
/// of a, b, c (exact zeros on the edge/vertex regions).
Eigen::Vector3d closestPointOnTriangle(const Eigen::Vector3d& p, const Eigen::Vector3d& a, const Eigen::Vector3d& b,
                                       const Eigen::Vector3d& c, Eigen::Vector3d* barycentric = nullptr);

struct SurfacePoint {
  Eigen::Vector3d point = Eigen::Vector3d::Zero();            ///< Closest point on the surface (mesh frame).
  double distance = std::numeric_limits<double>::infinity();  ///< |query - point| (mm).
  Eigen::Index face = -1;                                     ///< Face holding the point.
  /// Weights of the face's vertices 0, 1, 2: point = sum w_i v_i.
  Eigen::Vector3d barycentric = Eigen::Vector3d::Zero();
};

struct SignedSurfacePoint : SurfacePoint {
  /// +distance outside, -distance inside (mesh wound counter-clockwise seen from outside).
  double signed_distance = 0.0;
};

struct RayHit {
  double t = 0.0;  ///< Line parameter: point = origin + t * direction.
  Eigen::Vector3d point = Eigen::Vector3d::Zero();
  Eigen::Index face = -1;
  Eigen::Vector3d barycentric = Eigen::Vector3d::Zero();
  /// True when the line enters through the front (outside) of the face:
  /// direction . face normal < 0.
  bool entering = false;
};

struct MeshLocatorOptions {
  /// Faces per BVH leaf; small leaves favour queries, large ones the build.
  int max_leaf_faces = 4;
};

/// A BVH over a copy of a mesh's triangles. Queries are const and may run
/// from several threads at once.
class MeshLocator {
 public:
  /// Throws InvalidArgumentError for an invalid mesh (see validateMesh) or one without faces.
  explicit MeshLocator(const TriangleMesh& mesh, const MeshLocatorOptions& options = {});

  [[nodiscard]] Eigen::Index faceCount() const { return faces_.rows(); }
  /// Unit normal of each face (zero for a zero-area face), in the mesh's face order.
  [[nodiscard]] const PointsN3& faceNormals() const { return face_normals_; }
  /// True when the mesh is closed and consistently oriented (signed distance is defined).
  [[nodiscard]] bool closed() const { return topology().closed; }

  /// The closest point on the surface (not just the closest vertex).
  [[nodiscard]] SurfacePoint closestPoint(const Eigen::Vector3d& query) const;

  /// The closest point if it lies within `max_distance` (mm), otherwise a
  /// result with face -1 and infinite distance. Faster than closestPoint for
  /// far queries (e.g. ICP with a rejection distance).
  [[nodiscard]] SurfacePoint closestPointWithin(const Eigen::Vector3d& query, double max_distance) const;

  /// Like closestPoint, with the sign from angle-weighted pseudo-normals
  /// (Baerentzen & Aanaes 2005), exact for closed meshes. Throws
  /// ComputationError for an open mesh unless `allow_open` is set, in which
  /// case the sign says on which side of the nearest feature the query lies.
  [[nodiscard]] SignedSurfacePoint signedClosestPoint(const Eigen::Vector3d& query, bool allow_open = false) const;

  /// All intersections of the line origin + t * direction with t in
  /// [t_min, t_max], sorted by t. A crossing through a shared edge or vertex is
  /// reported once. Throws InvalidArgumentError for a zero or non-finite direction.
  [[nodiscard]] std::vector<RayHit> intersectLine(const Eigen::Vector3d& origin, const Eigen::Vector3d& direction,
                                                  double t_min = -std::numeric_limits<double>::infinity(),
                                                  double t_max = std::numeric_limits<double>::infinity()) const;

  /// Hits with t >= 0.
  [[nodiscard]] std::vector<RayHit> intersectRay(const Eigen::Vector3d& origin,
                                                 const Eigen::Vector3d& direction) const {
    return intersectLine(origin, direction, 0.0);
  }

  /// Hits between a and b; t in [0, 1] is the fraction along a -> b.
  [[nodiscard]] std::vector<RayHit> intersectSegment(const Eigen::Vector3d& a, const Eigen::Vector3d& b) const {
    return intersectLine(a, b - a, 0.0, 1.0);
  }

  /// The same surface with its vertices moved (a deforming soft tissue: same count, same faces): the tree is
  /// kept and its boxes recomputed, O(faces) instead of a build's O(faces log faces). Queries stay exact; the
  /// boxes loosen when faces move far from where the tree grouped them (rebuild then). Throws
  /// InvalidArgumentError for another vertex count or a non-finite vertex.
  [[nodiscard]] MeshLocator refitted(const PointsN3& vertices) const;

  /// Closest point by testing every face: the reference for tests and benchmarks.
  [[nodiscard]] SurfacePoint closestPointBruteForce(const Eigen::Vector3d& query) const;

 private:
  struct Node {
    Eigen::Vector3d lo = Eigen::Vector3d::Zero();
    Eigen::Vector3d hi = Eigen::Vector3d::Zero();
    // Leaf (count > 0): faces order_[first, first + count). Inner: children left and right.
    std::int32_t first = 0;
    std::int32_t count = 0;  // 0 for inner nodes
    std::int32_t left = -1;
    std::int32_t right = -1;
  };

  // An inner node for the closest-point search: its two children's boxes
  // (float, rounded outwards) and, per child, a search-node index (count 0)
  // or a leaf's faces [first, first + count). One cache line.
  struct alignas(64) SearchNode {
    float lo[2][3] = {};
    float hi[2][3] = {};
    std::int32_t first[2] = {0, 0};
    std::int32_t count[2] = {0, 0};
  };

  void build(const MeshLocatorOptions& options);
  void boundNodes(std::vector<Node>& nodes, std::size_t from, std::size_t to) const;
  void buildSearchNodes();
  // What only signed queries need, found on first use (thread-safe): the
  // closedness test and the pseudo-normals cost more than the BVH itself,
  // and ICP or unsigned distances never ask for them.
  struct Topology {
    std::once_flag once;
    bool closed = false;
    PointsN3 vertex_pseudo_normals;
    std::vector<Eigen::Vector3d> edge_pseudo_normals;  // 3 per face: edge k joins corners k and k+1
  };
  [[nodiscard]] const Topology& topology() const;
  void computePseudoNormals(Topology& t) const;
  void testFace(const Eigen::Vector3d& query, Eigen::Index slot, SurfacePoint& best) const;

  PointsN3 vertices_;
  Eigen::Matrix<std::int32_t, Eigen::Dynamic, 3, Eigen::RowMajor> faces_;
  std::vector<Node> nodes_;
  std::vector<SearchNode> search_nodes_;  // inner nodes, root first
  std::vector<std::int32_t> order_;                        // face indices, grouped by leaf
  std::vector<std::array<Eigen::Vector3d, 3>> triangles_;  // corners of face order_[i]
  std::shared_ptr<Topology> topology_ = std::make_shared<Topology>();  // shared by copies (same mesh)
  PointsN3 face_normals_;
  double scale_ = 1.0;                                // bounding-box diagonal, for tolerances
};

}  // namespace mrsns
