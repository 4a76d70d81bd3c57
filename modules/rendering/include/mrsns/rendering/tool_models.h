#pragma once
// Simple generated models of the tracked tools and the robot's end effector,
// built from cylinders, cones and boxes, so the scene needs no model files.
#include <Eigen/Core>

#include "mrsns/core/mesh.h"
#include "mrsns/rendering/scene.h"

namespace mrsns::rendering {

/// The model of `kind` in its tip frame (tip at the origin, the body along
/// +z, mm), closed and wound counter-clockwise seen from outside, with
/// vertex normals. frame: "<Kind>Tip" (e.g. "StylusTip").
[[nodiscard]] TriangleMesh toolModel(ToolKind kind);

/// A closed cylinder from `a` to `b` (mm) of `radius`, `sides` segments
/// (>= 3), caps included. Throws InvalidArgumentError when a == b, radius <= 0.
[[nodiscard]] TriangleMesh cylinderMesh(const Eigen::Vector3d& a, const Eigen::Vector3d& b, double radius,
                                        int sides = 16);
/// A closed cone (or truncated cone when radius_b > 0) from `a` to `b`.
[[nodiscard]] TriangleMesh coneMesh(const Eigen::Vector3d& a, const Eigen::Vector3d& b, double radius_a,
                                    double radius_b, int sides = 16);
/// A closed axis-aligned box between two corners.
[[nodiscard]] TriangleMesh boxMesh(const Eigen::Vector3d& lo, const Eigen::Vector3d& hi);
/// A closed UV sphere.
[[nodiscard]] TriangleMesh sphereMesh(const Eigen::Vector3d& center, double radius, int slices = 16, int stacks = 8);

}  // namespace mrsns::rendering
