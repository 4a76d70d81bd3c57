// The workstation's own figures (issue 10), under Xvfb/Mesa:
//
// BM_GuiStartup: one QApplication, then per iteration a MainWindow at
// 1280x800 opening the (already prepared) sample session, shown, events
// processed until the window is exposed and the 3D view has rendered once,
// then destroyed. BM_GuiStartupFreshSample: the same on a fresh copy of the
// sample, so the first open's Patient registration (which generates the
// phantom's models) is included, as on a fresh install.
//
// BM_HologramLatencyWhileRendering: a workflow::NavigationLoop on the
// simulated tracker (100 Hz) streams holograms (stream_holograms) to an
// OpenIGTLink client on 127.0.0.1 (igtlink::Client) while the GUI's 3D view
// renders the sample session without pause, a tracked stylus moving in it.
// Latency = client receive time - sample time, the sample time being the
// TRANSFORM header's timestamp (the PatientToTracker sample's, seconds since
// the simulated tracker started) plus the tracker's start (see below:
// latencies are lower bounds exact to the run's smallest latency).
//
// BM_SliceScrolling, BM_ScrewDragging (issue 17): the workstation at
// 1280x800 on a clinical-size CT (large_ct_case.h: 512 x 512 x 400 voxels
// from the real CT, L1-L4, the aorta, IVC and spinal cord meshed, bilateral
// screws at L1 and L2 planned). Scrolling: one wheel step on the axial view
// per iteration, as a wheel event does it (the slice moves one voxel, the
// three slice views and the crosshair re-rendered). Dragging: the L1 left
// screw's entry dragged on the axial view one pixel per mouse move, each
// move as the mouse does it: the slice and trajectory views re-rendered on
// every move, the screw's figures recomputed on the anatomy at 10 Hz and the
// 3D view re-rendered at 15 Hz (main_window_planning.cpp says why). Frames
// per second are moves per second; the goal is 30 on Mesa llvmpipe.
//
//   xvfb-run -a -s "-screen 0 1920x1080x24" build/tests/benchmarks/mrsns_bench_gui
#include <benchmark/benchmark.h>
#include <unistd.h>

#include <QApplication>
#include <QCheckBox>
#include <QElapsedTimer>
#include <QStandardPaths>
#include <QTest>
#include <QTimer>
#include <algorithm>
#include <atomic>
#include <chrono>
#include <filesystem>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include "display_area.h"
#include "large_ct_case.h"
#include "mrsns/rendering/slice_views.h"
#include "main_window.h"
#include "message_presenter.h"
#include "mrsns/igtlink/client.h"
#include "mrsns/rendering/scene.h"
#include "mrsns/rendering/tool_models.h"
#include "mrsns/workflow/navigation.h"

namespace {

using Clock = std::chrono::steady_clock;
using namespace mrsns;
namespace fs = std::filesystem;

QApplication& app() {
  static int argc = 1;
  static char name[] = "mrsns_bench_gui";
  static char* argv[] = {name, nullptr};
  static QApplication* a = [] {
    gui::prepareOpenGlSurfaceFormat();
    QStandardPaths::setTestModeEnabled(true);  // no user settings touched
    auto* created = new QApplication(argc, argv);
    QApplication::setOrganizationName(QStringLiteral("MR-SNS-bench"));
    QApplication::setApplicationName(QStringLiteral("mrsns-bench-gui"));
    return created;
  }();
  return *a;
}

fs::path sampleCopy() {
  static const fs::path dir = fs::temp_directory_path() / ("mrsns_bench_gui_" + std::to_string(::getpid()));
  return dir / "sample";
}

gui::MainWindowOptions windowOptions() {
  gui::MainWindowOptions options;
  options.presenter = std::make_shared<gui::RecordingPresenter>();
  options.remember_window_state = false;
  options.sample_work_folder = QString::fromStdString(sampleCopy().string());
  return options;
}

/// Constructs, shows, opens the sample, renders once; returns ms to the first render.
double openAndRender(bool* ok) {
  QElapsedTimer timer;
  timer.start();
  double to_first_render_ms = 0.0;
  {
    gui::MainWindow window(windowOptions());
    window.resize(1280, 800);
    window.show();
    *ok = window.openSampleSession() && QTest::qWaitForWindowExposed(&window, 10000);
    window.displayArea()->render();
    to_first_render_ms = static_cast<double>(timer.nsecsElapsed()) * 1e-6;
  }
  QApplication::processEvents();  // deferred deletes
  return to_first_render_ms;
}

void startupBenchmark(benchmark::State& state, bool fresh) {
  app();
  bool ok = true;
  if (!fresh) openAndRender(&ok);  // prepares the copy once, outside the timing
  double sum_ms = 0.0;
  for (auto _ : state) {
    if (fresh) {
      state.PauseTiming();
      fs::remove_all(sampleCopy());
      state.ResumeTiming();
    }
    sum_ms += openAndRender(&ok);
    if (!ok) {
      state.SkipWithError("the sample session did not open (is it bundled?) or the window was not exposed");
      break;
    }
  }
  state.counters["to_first_render_ms"] = benchmark::Counter(sum_ms, benchmark::Counter::kAvgIterations);
}

void BM_GuiStartup(benchmark::State& state) {
  startupBenchmark(state, false);
}
BENCHMARK(BM_GuiStartup)->Unit(benchmark::kMillisecond)->UseRealTime()->Iterations(10);

void BM_GuiStartupFreshSample(benchmark::State& state) {
  startupBenchmark(state, true);
}
BENCHMARK(BM_GuiStartupFreshSample)->Unit(benchmark::kMillisecond)->UseRealTime()->Iterations(5);

void BM_HologramLatencyWhileRendering(benchmark::State& state) {
  app();
  for (auto _ : state) {
    gui::MainWindow window(windowOptions());
    window.resize(1280, 800);
    window.show();
    if (!window.openSampleSession() || !QTest::qWaitForWindowExposed(&window, 10000)) {
      state.SkipWithError("the sample session did not open or the window was not exposed");
      break;
    }
    auto& scene = window.displayArea()->scene();
    scene.setTool("tool:Stylus", rendering::ToolKind::Stylus, Eigen::Vector3d(0.95, 0.85, 0.3));

    workflow::NavigationOptions options;
    options.devices.rate_hz = 100.0;
    options.stream_holograms = true;
    options.hologram_port = 0;
    std::vector<tracking::HologramModel> models{
        {"Spine", rendering::sphereMesh(Eigen::Vector3d::Zero(), 20.0), "Preop"}};
    workflow::NavigationLoop loop(options, std::move(models));
    // Registration and HMD calibration: the persistent edges of Eq. 1.
    const double no_time = std::numeric_limits<double>::quiet_NaN();
    loop.repository().setTransform("Preop", "Patient", Eigen::Isometry3d::Identity(), TransformStatus::Ok, no_time,
                                   true);
    Eigen::Isometry3d tracker_T_hologram = Eigen::Isometry3d::Identity();
    tracker_T_hologram.translation() = Eigen::Vector3d(0.0, 300.0, -500.0);
    loop.repository().setTransform("Hologram", "Tracker", tracker_T_hologram, TransformStatus::Ok, no_time, true);

    const auto before = Clock::now();
    loop.start();

    std::mutex mutex;
    std::vector<std::pair<Clock::time_point, double>> received;  // (receive time, sample time since t0)
    igtlink::ClientOptions client_options;
    client_options.port = loop.status().hologram_port;
    igtlink::Client hmd(client_options);
    hmd.onMessage([&](const igtlink::Message& m) {
      const auto now = Clock::now();
      if (m.header.type != "TRANSFORM") return;
      std::lock_guard lock(mutex);
      received.emplace_back(now, m.header.timestampSeconds());
    });
    hmd.start();

    // The 3D view renders back to back; the stylus follows the tracker.
    std::atomic<int> frames{0};
    QTimer render;
    QObject::connect(&render, &QTimer::timeout, [&] {
      const auto& repository = loop.repository();
      if (repository.hasFrame("Stylus") && repository.hasFrame("Tracker")) {
        const auto r = repository.getTransform("Stylus", "Tracker");
        if (r.ok()) scene.setPose("tool:Stylus", r.to_T_from);
      }
      window.displayArea()->renderScene();
      ++frames;
    });
    render.start(0);
    QElapsedTimer run;
    run.start();
    QTest::qWait(static_cast<int>(state.range(0)));
    const double seconds = static_cast<double>(run.elapsed()) * 1e-3;
    render.stop();
    hmd.stop();
    loop.stop();

    std::lock_guard lock(mutex);
    // The tracker's clock starts on its own thread inside start(): after
    // `before`, and (latency >= 0) no later than any receive time minus its
    // sample time. A loaded machine can start that thread hundreds of ms
    // after start() returns, so `after` is no estimate; the latest possible
    // start is, and makes these latencies lower bounds, exact up to the
    // smallest latency of the run (tens of microseconds on loopback).
    auto t0 = Clock::time_point::max();
    for (const auto& [at, sample_s] : received) {
      t0 = std::min(t0, at - std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(sample_s)));
    }
    std::vector<double> latencies_ms;
    for (const auto& [at, sample_s] : received) {
      const auto sample = t0 + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(sample_s));
      latencies_ms.push_back(std::chrono::duration<double, std::milli>(at - sample).count());
    }
    std::sort(latencies_ms.begin(), latencies_ms.end());
    auto percentile = [&](double p) {
      return latencies_ms.empty() ? 0.0 : latencies_ms[static_cast<std::size_t>(p * (latencies_ms.size() - 1))];
    };
    state.counters["p50_ms"] = percentile(0.50);
    state.counters["p99_ms"] = percentile(0.99);
    state.counters["max_ms"] = latencies_ms.empty() ? 0.0 : latencies_ms.back();
    state.counters["received"] = static_cast<double>(latencies_ms.size());
    state.counters["batches"] = static_cast<double>(loop.status().batches);
    state.counters["render_fps"] = frames.load() / seconds;
    state.counters["loop_latency_ms"] = loop.status().mean_loop_latency_ms;
    // How long after start() was called the tracker's clock started (at the latest).
    if (!received.empty()) {
      state.counters["tracker_start_ms"] = std::chrono::duration<double, std::milli>(t0 - before).count();
    }
    if (latencies_ms.empty()) state.SkipWithError("the client received no TRANSFORM");
  }
}
BENCHMARK(BM_HologramLatencyWhileRendering)->Arg(5000)->Iterations(1)->Unit(benchmark::kMillisecond)->UseRealTime();

/// A session on the large CT with its models and four screws, made once per run.
fs::path planningSession(std::string& why) {
  static fs::path made;
  if (!made.empty()) return made;
  const auto c = bench::largeCtCase(why);
  if (!c) return {};
  const fs::path dir = sampleCopy().parent_path() / "planning";
  fs::remove_all(dir);
  auto s = workflow::Session::create(dir);
  const workflow::StepContext quiet;
  bool ok = workflow::runStep(s, "import-ct", {{"path", c->ct.string()}}, quiet).ok &&
            workflow::runStep(s, "import-label-map", {{"path", c->labels.string()}}, quiet).ok &&
            workflow::runStep(s, "make-models", {{"labels", "L1,L2,L3,L4,aorta,inferior_vena_cava,spinal_cord"}}, quiet)
                .ok;
  const char* screws[][3] = {{"L1 left", "25.5,-84,382", "5.5,-134,382"},
                             {"L1 right", "-18.5,-84,382", "1.5,-134,382"},
                             {"L2 left", "24,-92,350", "10,-142,356"},
                             {"L2 right", "-17,-93,355", "-5,-143,358"}};
  for (const auto& screw : screws) {
    ok = ok && workflow::runStep(s, "plan-screw",
                                 {{"name", screw[0]}, {"entry", screw[1]}, {"target", screw[2]}, {"diameter_mm", 6.0},
                                  {"length_mm", 45.0}},
                                 quiet)
                   .ok;
  }
  if (!ok) {
    why = "the planning session on the large CT could not be made";
    return {};
  }
  made = dir;
  return made;
}

/// The window at 1280x800 on the planning session, shown, with the slice views at L1; null (and `why`) when not.
std::unique_ptr<gui::MainWindow> planningWindow(std::string& why) {
  app();
  const fs::path folder = planningSession(why);
  if (folder.empty()) return nullptr;
  auto window = std::make_unique<gui::MainWindow>(windowOptions());
  window->resize(1280, 800);
  window->show();
  if (!window->openSession(QString::fromStdString(folder.string())) || !QTest::qWaitForWindowExposed(window.get(), 10000)) {
    why = "the planning session did not open or the window was not exposed";
    return nullptr;
  }
  if (!window->displayArea()->hasOpenGlViews()) {
    why = "no OpenGL views on this display";
    return nullptr;
  }
  window->displayArea()->slices().setCursor(Eigen::Vector3d(0.0, -100.0, 382.0));
  window->displayArea()->render();
  QApplication::processEvents();
  return window;
}

void BM_SliceScrolling(benchmark::State& state) {
  std::string why;
  auto window = planningWindow(why);
  if (!window) {
    state.SkipWithError(why.c_str());
    return;
  }
  auto* display = window->displayArea();
  const int axial = static_cast<int>(rendering::SliceOrientation::Axial);
  int step = 1, taken = 0;
  for (auto _ : state) {
    // Up through 40 slices and back down, staying in the vertebrae.
    if (++taken % 40 == 0) step = -step;
    display->sliceWheel(axial, step);
    QApplication::processEvents();
  }
  state.counters["fps"] = benchmark::Counter(static_cast<double>(state.iterations()), benchmark::Counter::kIsRate);
}
BENCHMARK(BM_SliceScrolling)->Unit(benchmark::kMillisecond)->UseRealTime()->Iterations(200);

void BM_ScrewDragging(benchmark::State& state) {
  std::string why;
  auto window = planningWindow(why);
  if (!window) {
    state.SkipWithError(why.c_str());
    return;
  }
  auto* display = window->displayArea();
  auto& slices = display->slices();
  const int axial = static_cast<int>(rendering::SliceOrientation::Axial);
  // The trajectory views shown along the selected screw, as a surgeon planning it has them (the slice views
  // make room for them: the screw's place on the axial view is taken after).
  if (auto* trajectory = window->findChild<QCheckBox*>("showTrajectory")) trajectory->setChecked(true);
  for (int pass = 0; pass < 3; ++pass) QApplication::processEvents();
  display->render();
  const auto plan = window->shownPlan();
  const auto from = plan.empty() ? std::nullopt : slices.displayPoint(rendering::SliceOrientation::Axial, plan[0].entry);
  if (!from) {
    state.SkipWithError("the L1 left screw's entry is not on the axial view");
    return;
  }
  display->slicePress(axial, from->x(), from->y());
  display->sliceMove(axial, from->x() + 4.0, from->y());  // past the drag threshold
  double dx = 4.0, direction = 1.0;
  for (auto _ : state) {
    if (dx > 24.0 || dx < -24.0) direction = -direction;
    dx += direction;
    display->sliceMove(axial, from->x() + dx, from->y());
    QApplication::processEvents();
  }
  display->sliceRelease(axial, from->x() + dx, from->y());
  const auto moved = window->shownPlan();
  state.counters["fps"] = benchmark::Counter(static_cast<double>(state.iterations()), benchmark::Counter::kIsRate);
  // The drag really moved the screw (its figures recomputed on the way): the entry's distance from where it began.
  state.counters["entry_moved_mm"] = moved.empty() ? 0.0 : (moved[0].entry - plan[0].entry).norm();
}
BENCHMARK(BM_ScrewDragging)->Unit(benchmark::kMillisecond)->UseRealTime()->Iterations(100);

}  // namespace

int main(int argc, char** argv) {
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  std::error_code ec;
  fs::remove_all(sampleCopy().parent_path(), ec);
  return 0;
}
