#pragma once
// POLYDATA <-> mrsns::TriangleMesh.
#include "mrsns/core/mesh.h"
#include "mrsns/igtlink/polydata.h"

namespace mrsns::igtlink {

/// Points, triangles as polygons, normals as a point "Normals" attribute and
/// colours as a point "Colors" RGBA attribute (alpha 1). Throws
/// InvalidArgumentError for negative face indices.
PolyDataContent polyDataFromMesh(const TriangleMesh& mesh);

/// Triangles from polygons (fan-split when a polygon has more than 3 corners)
/// and triangle strips; lines and vertices are dropped. Normals from the first
/// 3-component point normal attribute, colours from the first point RGBA
/// attribute. Throws FormatError when an index is out of range or a cell has
/// fewer than 3 corners.
TriangleMesh meshFromPolyData(const PolyDataContent& polydata);

}  // namespace mrsns::igtlink
