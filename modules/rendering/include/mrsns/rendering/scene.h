#pragma once
// The 3D navigation scene: vertebrae, soft tissue coloured by posterior
// uncertainty, planned screw paths, tools, the live ultrasound slice and the
// robot end effector, as named objects a navigation loop updates every frame.
// VTK stays behind this header (only forward-declared), and Qt never enters:
// the GUI embeds renderer() in its own widget.
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstddef>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include "mrsns/core/image.h"
#include "mrsns/core/mesh.h"
#include "mrsns/core/plane_intersection.h"

class vtkRenderer;
class vtkRenderWindow;

namespace mrsns::rendering {

/// Generated tool models. Each is drawn in the tool's tip frame: the tip at
/// the origin, the shaft running from the tip along +z (so the tool points
/// along -z); setPose() places that frame in the world.
enum class ToolKind {
  Stylus,       ///< 150 mm pointer: a thin shaft, a handle and a marker cross
  Drill,        ///< 8 mm bit of 60 mm, a drill body and a handle
  EndEffector,  ///< a UR5-like flange with a tool holder, its axis along +z
};

/// Which geometry meshes are drawn with.
enum class DetailMode {
  Full,         ///< always the full meshes
  Interactive,  ///< always the decimated copies (meshes above LodOptions::min_triangles)
  /// Decimated while the user moves the camera (the GUI calls
  /// setInteracting() from its interactor's start/end interaction events),
  /// full when the view is still.
  Automatic,
};

struct LodOptions {
  /// Meshes with fewer triangles than this are never decimated.
  std::size_t min_triangles = 5000;
  /// Fraction of triangles the decimated copy keeps (vtkQuadricDecimation).
  double keep_fraction = 0.15;
};

/// What the scene holds now; stats() in the benchmark and the trial report.
struct SceneStats {
  std::size_t objects = 0;
  std::size_t triangles_full = 0;         ///< all visible meshes at full detail
  std::size_t triangles_interactive = 0;  ///< the same with decimated copies where they exist
};

class Scene {
 public:
  Scene();
  ~Scene();
  Scene(const Scene&) = delete;
  Scene& operator=(const Scene&) = delete;

  /// The renderer holding every object; the GUI adds it to its render window.
  [[nodiscard]] vtkRenderer* renderer() const;

  /// Adds or replaces the mesh `name` (vertices in the object frame, placed by
  /// setPose(), identity until then). Replacing a mesh with the same vertex
  /// and face count updates the points in place without rebuilding the
  /// pipeline. Throws InvalidArgumentError for an empty or invalid mesh, an
  /// opacity outside [0, 1] or an rgb outside [0, 1].
  void setMesh(const std::string& name, const TriangleMesh& mesh, const Eigen::Vector3d& rgb, double opacity = 1.0);

  /// Moves the vertices of mesh `name` in place (same count, same topology:
  /// a deforming soft-tissue model every frame). Throws InvalidArgumentError
  /// for an unknown name or a different vertex count.
  void updateMeshVertices(const std::string& name,
                          const Eigen::Matrix<double, Eigen::Dynamic, 3, Eigen::RowMajor>& vertices);

  /// Colours mesh `name` by one scalar per vertex through a blue-to-red lookup
  /// table over [lo, hi] and shows a scalar bar titled `title` (e.g. the
  /// posterior uncertainty in mm). Throws InvalidArgumentError for an unknown
  /// mesh, a size other than its vertex count, non-finite values or lo >= hi.
  void setMeshScalars(const std::string& name, const std::vector<double>& per_vertex, double lo, double hi,
                      const std::string& title = "Uncertainty (mm)");
  /// Back to the mesh's plain colour; the scalar bar goes when no mesh uses it.
  void clearMeshScalars(const std::string& name);

  /// Places object `name` (any kind) in the world. Cheap: only the actor's
  /// matrix changes. Throws InvalidArgumentError for an unknown name.
  void setPose(const std::string& name, const Eigen::Isometry3d& world_T_object);

  /// A straight line from `a` to `b` (world mm), e.g. a tool's trajectory.
  void setLine(const std::string& name, const Eigen::Vector3d& a, const Eigen::Vector3d& b, const Eigen::Vector3d& rgb);

  /// Outlines (world mm), e.g. the lumens segmented in the live ultrasound frame: each polyline drawn as a
  /// line strip, closed ones back to their first point; replaced whole at each call (an empty list shows
  /// nothing). Throws InvalidArgumentError for a non-finite point or an rgb outside [0, 1].
  void setPolylines(const std::string& name, const std::vector<Polyline3d>& lines, const Eigen::Vector3d& rgb);

  /// A planned screw path: a tube of `diameter_mm` from entry to target with
  /// a sphere at each end (entry slightly larger), world mm.
  void setScrewPath(const std::string& name, const Eigen::Vector3d& entry, const Eigen::Vector3d& target,
                    double diameter_mm, const Eigen::Vector3d& rgb);

  /// A generated tool model (see ToolKind) in its tip frame; move it with setPose().
  void setTool(const std::string& name, ToolKind kind, const Eigen::Vector3d& rgb);

  /// The live ultrasound frame as a textured plane. `frame_2d` is one slice
  /// (size[2] == 1) of any pixel type, grey-mapped over its own range (uint8
  /// as is); world_T_image maps the frame's physical coordinates (its origin,
  /// spacing and direction, mm) to the world. A new frame of the same size
  /// reuses the texture. Throws InvalidArgumentError for an empty or 3D image.
  void setUltrasoundSlice(const std::string& name, const ImageVolume& frame_2d, const Eigen::Isometry3d& world_T_image);
  /// The same with an affine pixel -> world map (i, j, 0, 1) -> mm, as
  /// ultrasound::placeImage() returns (scaling included).
  void setUltrasoundSlice(const std::string& name, const ImageVolume& frame_2d, const Eigen::Matrix4d& world_T_pixel);

  void setVisible(const std::string& name, bool visible);
  [[nodiscard]] bool contains(const std::string& name) const;
  [[nodiscard]] std::vector<std::string> names() const;
  /// Removes `name`; nothing happens when it does not exist.
  void remove(const std::string& name);
  void clear();

  /// Fits the camera to every visible object (anterior view, superior up).
  void resetCamera();
  /// Camera looking from `position` at `focal_point` with `view_up` (world mm).
  void setCamera(const Eigen::Vector3d& position, const Eigen::Vector3d& focal_point, const Eigen::Vector3d& view_up);
  void setBackground(const Eigen::Vector3d& rgb);

  void setDetailMode(DetailMode mode);
  [[nodiscard]] DetailMode detailMode() const;
  /// The camera is being moved (only matters in DetailMode::Automatic).
  void setInteracting(bool interacting);
  /// True when meshes are drawn from their decimated copies now.
  [[nodiscard]] bool drawingDecimated() const;
  void setLodOptions(const LodOptions& options);
  [[nodiscard]] SceneStats stats() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

/// Renders `scene` offscreen at width x height and writes an RGB PNG. Throws
/// InvalidArgumentError for a size outside [16, 8192] and FileError when the
/// PNG cannot be written (the message names the path).
void snapshotPng(Scene& scene, const std::filesystem::path& png, int width, int height);

}  // namespace mrsns::rendering
