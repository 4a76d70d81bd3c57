#pragma once
// Triangle-mesh files: STL (ASCII and binary), VTK XML polydata (.vtp),
// legacy VTK polydata (.vtk), Wavefront OBJ and PLY. Polygons and triangle
// strips are triangulated on reading; per-vertex normals and colours are kept
// where the file has them.
#include <filesystem>
#include <string>

#include "mrsns/core/mesh.h"

namespace mrsns::io {

enum class MeshFormat { Stl, Vtp, VtkLegacy, Obj, Ply };

/// The format implied by the file name's extension; throws UnsupportedError
/// (naming the file) for other extensions.
MeshFormat meshFormatFromPath(const std::filesystem::path& path);

/// "stl", "vtp", "vtk", "obj", "ply".
std::string meshFormatName(MeshFormat format);

/// Reads a mesh (format from the extension). `name` is set to the file stem.
/// A file holding only lines or vertices (e.g. 2D outlines, point sets) gives
/// vertices and no faces. Throws FileError when the file cannot be opened and
/// FormatError naming the file when its content is malformed: no points, no
/// cells, non-finite coordinates, out-of-range indices, a binary STL whose
/// size disagrees with its triangle count, or any error reported by VTK.
TriangleMesh readMesh(const std::filesystem::path& path);

struct MeshWriteOptions {
  bool binary = true;    ///< binary STL/PLY/VTK/VTP data (ASCII otherwise); OBJ is always text
  bool compress = true;  ///< zlib-compressed VTP data
};

/// Writes a mesh (format from the extension) with its normals and colours
/// where the format holds them (STL holds neither). Throws
/// InvalidArgumentError for a mesh with non-finite vertices or face indices
/// out of range, FileError when the file cannot be written.
void writeMesh(const TriangleMesh& mesh, const std::filesystem::path& path, const MeshWriteOptions& options = {});

}  // namespace mrsns::io
