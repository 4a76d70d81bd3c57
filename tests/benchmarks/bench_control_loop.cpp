// One 500 Hz control cycle of the robot loop: tracking snapshot in, safety supervisor (every check,
// including the drill tip against a 20k-vertex soft-tissue surface), guidance (IK nearest the current
// joints), one command out to the simulated UR5. Reports the mean, p50, p99 and max cycle time; the
// budget is the 2 ms period.
#include <benchmark/benchmark.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <memory>
#include <numbers>
#include <vector>

#include "mrsns/core/mesh.h"
#include "mrsns/core/mesh_locator.h"
#include "mrsns/core/rigid.h"
#include "mrsns/robot/control_loop.h"
#include "mrsns/robot/simulated_arm.h"

namespace {

using namespace mrsns;
using namespace mrsns::robot;

// A closed tube of rings x segments vertices (~20k) around an axis beside the drill path.
TriangleMesh tube(const Eigen::Vector3d& c, const Eigen::Vector3d& axis, double radius, int rings, int segments) {
  TriangleMesh m;
  m.vertices.resize(rings * segments, 3);
  const Eigen::Vector3d a = axis.normalized(), u = a.unitOrthogonal(), v = a.cross(u);
  for (int r = 0; r < rings; ++r) {
    for (int s = 0; s < segments; ++s) {
      const double th = 2 * std::numbers::pi * s / segments;
      const Eigen::Vector3d p = c + (r - rings / 2) * 0.8 * a + radius * (std::cos(th) * u + std::sin(th) * v);
      m.vertices.row(r * segments + s) = p.transpose();
    }
  }
  m.faces.resize(2 * (rings - 1) * segments, 3);
  int f = 0;
  for (int r = 0; r + 1 < rings; ++r) {
    for (int s = 0; s < segments; ++s) {
      const int i0 = r * segments + s, i1 = r * segments + (s + 1) % segments;
      m.faces.row(f++) << i0, i1, i1 + segments;
      m.faces.row(f++) << i0, i1 + segments, i0 + segments;
    }
  }
  return m;
}

struct Bench {
  std::shared_ptr<SimulatedArm> arm;
  Ur5Kinematics kin;
  std::unique_ptr<ControlLoop> loop;
  Eigen::Isometry3d base_T_tracker = Eigen::Isometry3d::Identity(), flange_T_marker = Eigen::Isometry3d::Identity();
  std::shared_ptr<const MeshLocator> tissue;

  void reset() {
    arm = std::make_shared<SimulatedArm>();
    base_T_tracker.translation() << -200, 1400, 500;
    flange_T_marker.translation() << 60, 0, 40;
    ControlLoopSetup setup;
    setup.flange_T_marker = flange_T_marker;
    setup.base_T_tracker = base_T_tracker;
    setup.flange_T_tip.translation() << 0, 0, 150;
    const Eigen::Isometry3d tip0 = arm->state().base_T_flange * setup.flange_T_tip;
    const Eigen::Vector3d dir = (tip0.linear() * Eigen::Vector3d(0.08, -0.05, 1.0)).normalized();
    setup.plan.name = "bench";
    setup.plan.entry = tip0.translation() + tip0.linear() * Eigen::Vector3d(8, 5, 45);
    setup.plan.target = setup.plan.entry + 30.0 * dir;
    if (!tissue) {
      tissue = std::make_shared<MeshLocator>(
          tube(setup.plan.entry + 12.0 * dir.unitOrthogonal(), dir.cross(dir.unitOrthogonal()), 4.0, 157, 128));
    }
    loop = std::make_unique<ControlLoop>(arm, kin, setup);
    loop->setSoftTissue(tissue);
    loop->enable();
    loop->startPlacement();
  }

  TrackingSnapshot sense() const {
    TrackingSnapshot t;
    t.time_s = static_cast<double>(loop->cycle()) * 0.002;
    t.drill_tracked = t.patient_tracked = true;
    t.drill_timestamp_s = t.patient_timestamp_s = t.time_s;
    t.tracker_T_drill = base_T_tracker.inverse() * arm->state().base_T_flange * flange_T_marker;
    t.tracker_T_patient = base_T_tracker.inverse();
    return t;
  }
};

void BM_ControlCycle(benchmark::State& state) {
  Bench b;
  b.reset();
  std::vector<double> us;
  us.reserve(200000);
  for (auto _ : state) {
    const auto s = b.loop->supervisor().state();
    if (s != SupervisorState::Aligning && s != SupervisorState::Advancing) {
      state.PauseTiming();
      b.reset();
      state.ResumeTiming();
    }
    const TrackingSnapshot snap = b.sense();
    const auto t0 = std::chrono::steady_clock::now();
    const CycleReport r = b.loop->tick(snap);
    const auto t1 = std::chrono::steady_clock::now();
    benchmark::DoNotOptimize(r);
    b.arm->step();
    us.push_back(std::chrono::duration<double, std::micro>(t1 - t0).count());
  }
  std::sort(us.begin(), us.end());
  auto pct = [&](double p) {
    return us.empty() ? 0.0 : us[std::min(us.size() - 1, static_cast<std::size_t>(p * us.size()))];
  };
  state.counters["cycle_p50_us"] = pct(0.50);
  state.counters["cycle_p99_us"] = pct(0.99);
  state.counters["cycle_max_us"] = us.empty() ? 0.0 : us.back();
  state.counters["budget_us"] = 2000;
  state.counters["soft_tissue_vertices"] = static_cast<double>(157 * 128);
}
BENCHMARK(BM_ControlCycle)->Unit(benchmark::kMicrosecond)->Iterations(20000);

// The parts: IK nearest, and the soft-tissue query alone.
void BM_InverseNearest(benchmark::State& state) {
  const Ur5Kinematics kin;
  const Joints q = (Joints() << 0.3, -1.2, 1.4, -1.7, -1.5, 0.2).finished();
  const auto T = kin.forward(q);
  for (auto _ : state) benchmark::DoNotOptimize(kin.inverseNearest(T, q));
}
BENCHMARK(BM_InverseNearest);

void BM_SoftTissueMarginQuery(benchmark::State& state) {
  const MeshLocator loc(tube(Eigen::Vector3d::Zero(), Eigen::Vector3d::UnitZ(), 4.0, 157, 128));
  double x = 0;
  for (auto _ : state) {
    x = std::fmod(x + 0.37, 20.0);
    benchmark::DoNotOptimize(loc.closestPointWithin(Eigen::Vector3d(8 + x * 0.1, 1, x - 10), 2.0));
  }
}
BENCHMARK(BM_SoftTissueMarginQuery);

}  // namespace

BENCHMARK_MAIN();
