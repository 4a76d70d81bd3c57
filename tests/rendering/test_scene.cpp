// Scene bookkeeping without a display: objects by name, errors for bad input,
// level-of-detail copies and how they follow a deforming mesh.
#include <gtest/gtest.h>
#include <vtkActor.h>
#include <vtkActorCollection.h>
#include <vtkMatrix4x4.h>
#include <vtkPolyData.h>
#include <vtkPolyDataMapper.h>
#include <vtkRenderer.h>

#include <random>

#include "mrsns/core/error.h"
#include "mrsns/rendering/scene.h"
#include "mrsns/rendering/tool_models.h"

using namespace mrsns;
using namespace mrsns::rendering;

namespace {

// A finely tessellated sphere: 128 x 64 gives ~16k triangles, above the LOD threshold.
TriangleMesh bigSphere() {
  return sphereMesh(Eigen::Vector3d::Zero(), 20.0, 128, 64);
}

// The points of every visible actor's mapper input.
std::vector<vtkPolyData*> visibleInputs(const Scene& scene) {
  std::vector<vtkPolyData*> out;
  vtkActorCollection* actors = scene.renderer()->GetActors();
  actors->InitTraversal();
  while (vtkActor* a = actors->GetNextActor()) {
    if (!a->GetVisibility()) continue;
    a->GetMapper()->Update();
    out.push_back(vtkPolyData::SafeDownCast(a->GetMapper()->GetInput()));
  }
  return out;
}

}  // namespace

TEST(Scene, ObjectsByName) {
  Scene scene;
  scene.setMesh("C5", sphereMesh(Eigen::Vector3d::Zero(), 5.0), Eigen::Vector3d(0.9, 0.9, 0.8));
  scene.setLine("trajectory", Eigen::Vector3d::Zero(), Eigen::Vector3d(0, 0, 50), Eigen::Vector3d(0, 1, 0));
  scene.setScrewPath("C5 left", Eigen::Vector3d(10, 20, 0), Eigen::Vector3d(5, -5, 0), 3.5, Eigen::Vector3d(0, 0.6, 1));
  scene.setTool("stylus", ToolKind::Stylus, Eigen::Vector3d(0.7, 0.7, 0.7));
  EXPECT_EQ(scene.names(), (std::vector<std::string>{"C5", "C5 left", "stylus", "trajectory"}));
  EXPECT_TRUE(scene.contains("stylus"));
  scene.remove("stylus");
  scene.remove("never added");  // no-op
  EXPECT_FALSE(scene.contains("stylus"));
  EXPECT_EQ(scene.stats().objects, 3u);
  scene.clear();
  EXPECT_TRUE(scene.names().empty());
  EXPECT_EQ(scene.renderer()->GetActors()->GetNumberOfItems(), 0);
}

TEST(Scene, BadInputIsRefusedWithTypedErrors) {
  Scene scene;
  const TriangleMesh ok = sphereMesh(Eigen::Vector3d::Zero(), 5.0);
  EXPECT_THROW(scene.setMesh("", ok, Eigen::Vector3d::Ones()), InvalidArgumentError);
  EXPECT_THROW(scene.setMesh("m", TriangleMesh{}, Eigen::Vector3d::Ones()), InvalidArgumentError);
  EXPECT_THROW(scene.setMesh("m", ok, Eigen::Vector3d(255, 0, 0)), InvalidArgumentError);
  EXPECT_THROW(scene.setMesh("m", ok, Eigen::Vector3d::Ones(), 1.5), InvalidArgumentError);
  TriangleMesh broken = ok;
  broken.faces(0, 0) = 100000;
  EXPECT_THROW(scene.setMesh("m", broken, Eigen::Vector3d::Ones()), InvalidArgumentError);
  EXPECT_THROW(scene.setPose("missing", Eigen::Isometry3d::Identity()), InvalidArgumentError);
  scene.setMesh("m", ok, Eigen::Vector3d::Ones());
  EXPECT_THROW(scene.setMeshScalars("m", std::vector<double>(3, 0.0), 0.0, 1.0), InvalidArgumentError);
  EXPECT_THROW(
      scene.setMeshScalars("m", std::vector<double>(static_cast<std::size_t>(ok.vertexCount()), 0.0), 1.0, 1.0),
      InvalidArgumentError);
  EXPECT_THROW(scene.updateMeshVertices("m", ok.vertices.topRows(3)), InvalidArgumentError);
  Eigen::Isometry3d nan_pose = Eigen::Isometry3d::Identity();
  nan_pose.translation().x() = std::nan("");
  EXPECT_THROW(scene.setPose("m", nan_pose), InvalidArgumentError);
  EXPECT_THROW(scene.setScrewPath("s", Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero(), 3.5, Eigen::Vector3d::Ones()),
               InvalidArgumentError);
  ImageVolume volume;
  volume.size = {4, 4, 2};
  volume.data.resize(volume.byteCount());
  EXPECT_THROW(scene.setUltrasoundSlice("us", volume, Eigen::Isometry3d::Identity()), InvalidArgumentError);
  volume.size = {4, 4, 1};  // data now too large for the declared size
  EXPECT_THROW(scene.setUltrasoundSlice("us", volume, Eigen::Isometry3d::Identity()), InvalidArgumentError);
  // Nothing half-built stays behind after a refusal.
  EXPECT_EQ(scene.names(), (std::vector<std::string>{"m"}));
}

TEST(Scene, PoseIsSharedByEveryActorOfAnObjectAndSurvivesReplacement) {
  Scene scene;
  scene.setScrewPath("path", Eigen::Vector3d(0, 0, 0), Eigen::Vector3d(0, 0, 30), 3.5, Eigen::Vector3d(0, 1, 0));
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  pose.translate(Eigen::Vector3d(10, -20, 30));
  pose.rotate(Eigen::AngleAxisd(0.7, Eigen::Vector3d(1, 2, 3).normalized()));
  scene.setPose("path", pose);
  vtkActorCollection* actors = scene.renderer()->GetActors();
  ASSERT_EQ(actors->GetNumberOfItems(), 3);
  actors->InitTraversal();
  while (vtkActor* a = actors->GetNextActor()) {
    vtkMatrix4x4* m = a->GetMatrix();
    for (int r = 0; r < 4; ++r)
      for (int c = 0; c < 4; ++c) EXPECT_NEAR(m->GetElement(r, c), pose.matrix()(r, c), 1e-12);
  }
  // A new tool model under the same name stays where the old one was.
  scene.setTool("tool", ToolKind::Stylus, Eigen::Vector3d::Ones());
  scene.setPose("tool", pose);
  scene.setTool("tool", ToolKind::Drill, Eigen::Vector3d::Ones());
  actors = scene.renderer()->GetActors();  // rebuilt from the props on every call
  actors->InitTraversal();
  int checked = 0;
  while (vtkActor* a = actors->GetNextActor()) {
    checked += std::abs(a->GetMatrix()->GetElement(0, 3) - 10.0) < 1e-12 ? 1 : 0;
  }
  EXPECT_EQ(checked, 4);
}

TEST(Scene, LargeMeshesGetADecimatedCopyDrawnInInteractiveMode) {
  Scene scene;
  LodOptions lod;
  lod.keep_fraction = 0.2;
  scene.setLodOptions(lod);
  const TriangleMesh sphere = bigSphere();
  scene.setMesh("tissue", sphere, Eigen::Vector3d(0.9, 0.6, 0.5));
  scene.setTool("drill", ToolKind::Drill, Eigen::Vector3d(0.6, 0.6, 0.6));  // small: no copy
  const SceneStats full = scene.stats();
  const auto tool_triangles = static_cast<std::size_t>(toolModel(ToolKind::Drill).faceCount());
  EXPECT_EQ(full.triangles_full, static_cast<std::size_t>(sphere.faceCount()) + tool_triangles);
  // Quadric decimation stops within a few percent of the requested reduction.
  const double kept =
      static_cast<double>(full.triangles_interactive - tool_triangles) / static_cast<double>(sphere.faceCount());
  EXPECT_NEAR(kept, 0.2, 0.03);

  EXPECT_FALSE(scene.drawingDecimated());
  auto drawn = [&] {
    std::size_t n = 0;
    for (vtkPolyData* p : visibleInputs(scene)) n += static_cast<std::size_t>(p->GetNumberOfPolys());
    return n;
  };
  EXPECT_EQ(drawn(), full.triangles_full);
  scene.setDetailMode(DetailMode::Interactive);
  EXPECT_TRUE(scene.drawingDecimated());
  EXPECT_EQ(drawn(), full.triangles_interactive);
  scene.setDetailMode(DetailMode::Automatic);
  EXPECT_EQ(drawn(), full.triangles_full);
  scene.setInteracting(true);
  EXPECT_EQ(drawn(), full.triangles_interactive);
  scene.setInteracting(false);
  EXPECT_EQ(drawn(), full.triangles_full);
}

TEST(Scene, DecimatedCopyFollowsARigidMotionOfTheFullMeshExactly) {
  // Property: when every full vertex moves by the same rigid translation, so
  // does every decimated vertex (each copies its nearest full vertex's
  // displacement), to float precision of vtkPoints.
  Scene scene;
  scene.setDetailMode(DetailMode::Interactive);
  const TriangleMesh sphere = bigSphere();
  scene.setMesh("tissue", sphere, Eigen::Vector3d(0.9, 0.6, 0.5));
  auto decimatedPoints = [&] {
    const auto inputs = visibleInputs(scene);
    EXPECT_EQ(inputs.size(), 1u);
    Eigen::MatrixXd p(inputs[0]->GetNumberOfPoints(), 3);
    for (vtkIdType i = 0; i < inputs[0]->GetNumberOfPoints(); ++i) {
      double x[3];
      inputs[0]->GetPoint(i, x);
      p.row(i) = Eigen::Vector3d(x[0], x[1], x[2]);
    }
    return p;
  };
  const Eigen::MatrixXd before = decimatedPoints();
  const Eigen::RowVector3d shift(3.0, -7.5, 12.25);
  Eigen::Matrix<double, Eigen::Dynamic, 3, Eigen::RowMajor> moved = sphere.vertices.rowwise() + shift;
  scene.updateMeshVertices("tissue", moved);
  const Eigen::MatrixXd after = decimatedPoints();
  ASSERT_EQ(after.rows(), before.rows());
  // float storage: ~1e-6 relative on coordinates of ~30 mm.
  EXPECT_LT(((after - before).rowwise() - shift).cwiseAbs().maxCoeff(), 1e-4);

  // And a smooth non-rigid deformation (radial bulge up to 2 mm) moves the
  // copy to within the decimation's own approximation of the surface: each
  // decimated vertex lies within the local vertex spacing of its source.
  Eigen::Matrix<double, Eigen::Dynamic, 3, Eigen::RowMajor> bulged = sphere.vertices;
  for (Eigen::Index i = 0; i < bulged.rows(); ++i) {
    const Eigen::Vector3d p = sphere.vertices.row(i);
    bulged.row(i) = p + 2.0 * std::max(0.0, p.z() / 20.0) * p.normalized();
  }
  scene.updateMeshVertices("tissue", bulged);
  const Eigen::MatrixXd bulged_copy = decimatedPoints();
  for (Eigen::Index i = 0; i < bulged_copy.rows(); ++i) {
    const Eigen::Vector3d q = bulged_copy.row(i);
    const Eigen::Vector3d rest = before.row(i);
    const double expected = 2.0 * std::max(0.0, rest.z() / 20.0);
    // Radial growth equals the bulge at that height within the sphere's
    // vertex spacing (2 pi 20 / 128 ~ 1 mm) times the bulge gradient (0.1/mm).
    EXPECT_NEAR(q.norm() - rest.norm(), expected, 0.15) << "decimated vertex " << i;
  }
}

TEST(Scene, SameTopologyMeshUpdatesInPlace) {
  Scene scene;
  const TriangleMesh sphere = sphereMesh(Eigen::Vector3d::Zero(), 5.0);
  scene.setMesh("m", sphere, Eigen::Vector3d::Ones());
  const auto before = visibleInputs(scene);
  TriangleMesh moved = sphere;
  moved.vertices.col(0).array() += 1.0;
  scene.setMesh("m", moved, Eigen::Vector3d(1, 0, 0));
  const auto after = visibleInputs(scene);
  ASSERT_EQ(after.size(), 1u);
  EXPECT_EQ(before[0], after[0]);  // the same vtkPolyData: the pipeline was kept
  double p[3];
  after[0]->GetPoint(0, p);
  EXPECT_NEAR(p[0], moved.vertices(0, 0), 1e-5);
}
