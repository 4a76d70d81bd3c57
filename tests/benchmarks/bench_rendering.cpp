// Frames per second of the full navigation scene at 1280x800 offscreen, with
// and without level of detail: the bundled cervical phantom's vertebrae, a
// 20k-vertex soft-tissue surface coloured by uncertainty and deforming every
// frame, a live 640x480 US slice, the planned screw paths, a stylus, a drill
// and the robot's end effector, all moving every frame. Needs an X display
// (xvfb-run -a); on Mesa's llvmpipe this measures software GL.
//   xvfb-run -a build/tests/benchmarks/mrsns_bench_rendering
#include <benchmark/benchmark.h>

#include <cmath>
#include <cstdlib>
#include <memory>
#include <numbers>
#include <random>
#include <string>

#include "mrsns/core/mesh_ops.h"
#include "mrsns/registration/label_meshing.h"
#include "mrsns/registration/phantom_cervical.h"
#include "mrsns/rendering/offscreen_view.h"
#include "mrsns/rendering/scene.h"
#include "mrsns/rendering/tool_models.h"

namespace {

using namespace mrsns;
using namespace mrsns::rendering;

struct NavigationScene {
  Scene scene;
  TriangleMesh tissue;
  ImageVolume frame;
  std::size_t vertebra_triangles = 0;
};

// Built once: the phantom and its meshing take a few seconds.
NavigationScene& navigationScene() {
  static std::unique_ptr<NavigationScene> s = [] {
    auto n = std::make_unique<NavigationScene>();
    registration::PhantomOptions options;
    options.spacing_mm = 0.8;
    const auto phantom = registration::generateCervicalPhantom(options);
    registration::LabelMeshOptions mesh_options;
    mesh_options.scheme = registration::LabelScheme::Verse;
    const auto vertebrae = registration::meshLabelMap(phantom.bone_labels, mesh_options);
    for (const auto& v : vertebrae.meshes) {
      n->scene.setMesh(v.name, v.mesh, Eigen::Vector3d(0.93, 0.88, 0.75));
      n->vertebra_triangles += static_cast<std::size_t>(v.mesh.faceCount());
    }
    for (const auto& p : phantom.screw_paths) {
      n->scene.setScrewPath(p.name, p.entry, p.tip(), p.diameter_mm, Eigen::Vector3d(0.1, 0.8, 0.3));
    }
    // Soft tissue: an ellipsoid of 200 x 100 -> 19,802 vertices around the spine.
    n->tissue = sphereMesh(Eigen::Vector3d::Zero(), 1.0, 200, 100);
    n->tissue.vertices = n->tissue.vertices * Eigen::Vector3d(50, 45, 65).asDiagonal();
    n->tissue.normals = vertexNormals(n->tissue);
    n->scene.setMesh("soft tissue", n->tissue, Eigen::Vector3d(0.9, 0.6, 0.55), 0.35);
    std::vector<double> sigma(static_cast<std::size_t>(n->tissue.vertexCount()));
    for (Eigen::Index i = 0; i < n->tissue.vertexCount(); ++i) {
      sigma[static_cast<std::size_t>(i)] = 1.0 + n->tissue.vertices(i, 2) / 65.0;
    }
    n->scene.setMeshScalars("soft tissue", sigma, 0.0, 2.0, "Posterior SD (mm)");
    n->frame.size = {640, 480, 1};
    n->frame.spacing = Eigen::Vector3d(0.1, 0.1, 1.0);
    n->frame.data.resize(n->frame.byteCount());
    n->scene.setUltrasoundSlice("us", n->frame, Eigen::Isometry3d::Identity());
    n->scene.setTool("stylus", ToolKind::Stylus, Eigen::Vector3d(0.75, 0.75, 0.8));
    n->scene.setTool("drill", ToolKind::Drill, Eigen::Vector3d(0.6, 0.6, 0.65));
    n->scene.setTool("end effector", ToolKind::EndEffector, Eigen::Vector3d(0.4, 0.5, 0.7));
    n->scene.resetCamera();
    return n;
  }();
  return *s;
}

// One navigation frame's updates: every tool moves, the US frame gets new
// pixels and moves with the probe, the soft tissue deforms.
void updateFrame(NavigationScene& n, int k) {
  const double t = 0.04 * k;
  auto pose = [&](double phase, const Eigen::Vector3d& at) {
    Eigen::Isometry3d p = Eigen::Isometry3d::Identity();
    p.translation() = at + 5.0 * Eigen::Vector3d(std::cos(t + phase), std::sin(t + phase), 0.0);
    p.linear() = Eigen::AngleAxisd(0.3 * std::sin(t + phase), Eigen::Vector3d::UnitX()).toRotationMatrix();
    return p;
  };
  n.scene.setPose("stylus", pose(0.0, Eigen::Vector3d(30, -60, 10)));
  n.scene.setPose("drill", pose(1.0, Eigen::Vector3d(-20, 40, 0)));
  n.scene.setPose("end effector", pose(2.0, Eigen::Vector3d(-20, 40, 160)));
  for (std::size_t i = 0; i < n.frame.data.size(); ++i) {
    n.frame.data[i] = static_cast<std::byte>((i * 7 + static_cast<std::size_t>(k) * 13) & 0xff);
  }
  Eigen::Isometry3d world_T_image = pose(0.5, Eigen::Vector3d(-32, -70, 30));
  world_T_image.linear() =
      world_T_image.linear() * Eigen::Matrix3d((Eigen::Matrix3d() << 1, 0, 0, 0, 0, 1, 0, -1, 0).finished());
  n.scene.setUltrasoundSlice("us", n.frame, world_T_image);
  Eigen::Matrix<double, Eigen::Dynamic, 3, Eigen::RowMajor> v = n.tissue.vertices;
  v.col(1) = v.col(1) * (1.0 + 0.02 * std::sin(t));
  n.scene.updateMeshVertices("soft tissue", v);
}

void runFrames(benchmark::State& state, DetailMode mode, double tissue_opacity = 0.35) {
  const char* display = std::getenv("DISPLAY");
  if (display == nullptr || *display == '\0') {
    state.SkipWithError("no X display: run under xvfb-run -a");
    return;
  }
  NavigationScene& n = navigationScene();
  n.scene.setDetailMode(mode);
  // Same faces: only colour and opacity change, in place.
  n.scene.setMesh("soft tissue", n.tissue, Eigen::Vector3d(0.9, 0.6, 0.55), tissue_opacity);
  OffscreenView view(n.scene, 1280, 800);
  view.render();  // first frame uploads the geometry
  int k = 0;
  double render_s = 0.0;
  for (auto _ : state) {
    updateFrame(n, k++);
    render_s += view.render();
  }
  // MRSNS_BENCH_SNAPSHOT=dir keeps the last frame of each mode to look at.
  if (const char* dir = std::getenv("MRSNS_BENCH_SNAPSHOT")) {
    view.writePng(std::string(dir) + "/navigation_" + (mode == DetailMode::Full ? std::string("full") : "lod") +
                  (tissue_opacity < 1.0 ? "" : "_opaque") + ".png");
  }
  const SceneStats stats = n.scene.stats();
  state.counters["fps"] = benchmark::Counter(static_cast<double>(state.iterations()), benchmark::Counter::kIsRate);
  state.counters["render_ms"] = 1000.0 * render_s / static_cast<double>(state.iterations());
  state.counters["triangles"] =
      static_cast<double>(mode == DetailMode::Full ? stats.triangles_full : stats.triangles_interactive);
  state.counters["vertebra_triangles"] = static_cast<double>(n.vertebra_triangles);
}

void BM_NavigationFrameFull(benchmark::State& state) {
  runFrames(state, DetailMode::Full);
}
void BM_NavigationFrameLod(benchmark::State& state) {
  runFrames(state, DetailMode::Interactive);
}
// Translucency costs extra full-screen passes (order-independent
// transparency): the same scene with opaque soft tissue.
void BM_NavigationFrameLodOpaqueTissue(benchmark::State& state) {
  runFrames(state, DetailMode::Interactive, 1.0);
}

}  // namespace

BENCHMARK(BM_NavigationFrameFull)->Unit(benchmark::kMillisecond)->UseRealTime()->MinTime(3.0);
BENCHMARK(BM_NavigationFrameLod)->Unit(benchmark::kMillisecond)->UseRealTime()->MinTime(3.0);
BENCHMARK(BM_NavigationFrameLodOpaqueTissue)->Unit(benchmark::kMillisecond)->UseRealTime()->MinTime(3.0);
BENCHMARK_MAIN();
