// Whole N-wire calibration of PLUS's fCal recordings (reading, segmentation
// of every frame, calibration, validation), and the segmentation alone in
// frames per second.
//   build-*/tests/benchmarks/mrsns_bench_us_calibration
#include <benchmark/benchmark.h>

#include <filesystem>

#include "mrsns/io/device_set.h"
#include "mrsns/io/sequence_file.h"
#include "mrsns/ultrasound/probe_calibration.h"

namespace {

const std::filesystem::path kDir = std::filesystem::path(MRSNS_BENCH_DATA_DIR) / "plus";

struct Data {
  mrsns::io::DeviceSetConfiguration config =
      mrsns::io::readDeviceSet(kDir / "PlusDeviceSet_fCal_Sim_SpatialCalibration_1.2.xml");
  mrsns::TrackedSequence calibration = mrsns::io::readSequence(kDir / "fCal_Test_Calibration_3NWires.igs.mha");
  mrsns::TrackedSequence validation = mrsns::io::readSequence(kDir / "fCal_Test_Validation_3NWires.igs.mha");
};

const Data& data() {
  static const Data d;
  return d;
}

bool haveData(benchmark::State& state) {
  if (std::filesystem::exists(kDir / "fCal_Test_Calibration_3NWires.igs.mha")) return true;
  state.SkipWithError("PLUS data not found under MRSNS_DATA_DIR/plus");
  return false;
}

// Everything from the files on disk to ImageToProbe and the validation
// figures (`calibrate-us --no-lag-check`).
void BM_CalibrationFromFiles(benchmark::State& state) {
  if (!haveData(state)) return;
  for (auto _ : state) {
    const auto config = mrsns::io::readDeviceSet(kDir / "PlusDeviceSet_fCal_Sim_SpatialCalibration_1.2.xml");
    const auto calibration = mrsns::io::readSequence(kDir / "fCal_Test_Calibration_3NWires.igs.mha");
    const auto validation = mrsns::io::readSequence(kDir / "fCal_Test_Validation_3NWires.igs.mha");
    const auto run = mrsns::ultrasound::calibrateProbe(config, calibration, validation);
    benchmark::DoNotOptimize(run.result.probe_T_image);
    state.counters["validation_mm"] = run.validation_errors.reprojection_3d_mean_mm;
  }
}
BENCHMARK(BM_CalibrationFromFiles)->Unit(benchmark::kMillisecond)->UseRealTime();

// What `mrsns-cli calibrate-us` does by default: the same, plus the lag
// check (the tracker lag searched on the calibration sweep, one solve per
// 20 ms step over +-1 s, and reported, not applied).
void BM_CalibrationWithLagCheckFromFiles(benchmark::State& state) {
  if (!haveData(state)) return;
  mrsns::ultrasound::TrackerLagOptions lag;
  lag.check = true;
  for (auto _ : state) {
    const auto config = mrsns::io::readDeviceSet(kDir / "PlusDeviceSet_fCal_Sim_SpatialCalibration_1.2.xml");
    const auto calibration = mrsns::io::readSequence(kDir / "fCal_Test_Calibration_3NWires.igs.mha");
    const auto validation = mrsns::io::readSequence(kDir / "fCal_Test_Validation_3NWires.igs.mha");
    const auto run = mrsns::ultrasound::calibrateProbe(config, calibration, validation, {}, lag);
    benchmark::DoNotOptimize(run.result.probe_T_image);
    state.counters["validation_mm"] = run.validation_errors.reprojection_3d_mean_mm;
    if (run.tracker_lag_check) state.counters["checked_lag_ms"] = run.tracker_lag_check->estimate.lag_s * 1e3;
  }
}
BENCHMARK(BM_CalibrationWithLagCheckFromFiles)->Unit(benchmark::kMillisecond)->UseRealTime();

// `calibrate-us --tracker-lag-ms auto --objective middle-wire`: the lag
// estimated from the calibration sweep and applied to both sequences.
void BM_CalibrationWithLagEstimateFromFiles(benchmark::State& state) {
  if (!haveData(state)) return;
  mrsns::ultrasound::TrackerLagOptions lag;
  lag.estimate = true;
  lag.fall_back_to_zero = true;
  for (auto _ : state) {
    const auto config = mrsns::io::readDeviceSet(kDir / "PlusDeviceSet_fCal_Sim_SpatialCalibration_1.2.xml");
    const auto calibration = mrsns::io::readSequence(kDir / "fCal_Test_Calibration_3NWires.igs.mha");
    const auto validation = mrsns::io::readSequence(kDir / "fCal_Test_Validation_3NWires.igs.mha");
    mrsns::ultrasound::SpatialCalibrationOptions spatial;
    spatial.objective = mrsns::ultrasound::CalibrationObjective::MiddleWirePoints;
    const auto run = mrsns::ultrasound::calibrateProbe(config, calibration, validation, spatial, lag);
    benchmark::DoNotOptimize(run.result.probe_T_image);
    state.counters["validation_mm"] = run.validation_errors.reprojection_3d_mean_mm;
    state.counters["lag_ms"] = run.tracker_lag.lag_s * 1e3;
  }
}
BENCHMARK(BM_CalibrationWithLagEstimateFromFiles)->Unit(benchmark::kMillisecond)->UseRealTime();

// Segmentation and calibration on sequences already in memory.
void BM_CalibrationInMemory(benchmark::State& state) {
  if (!haveData(state)) return;
  const auto& d = data();
  for (auto _ : state) {
    const auto run = mrsns::ultrasound::calibrateProbe(d.config, d.calibration, d.validation);
    benchmark::DoNotOptimize(run.result.probe_T_image);
  }
}
BENCHMARK(BM_CalibrationInMemory)->Unit(benchmark::kMillisecond)->UseRealTime();

// Segmentation alone, `threads` workers; items/s = frames/s.
void BM_Segmentation(benchmark::State& state) {
  if (!haveData(state)) return;
  const auto& d = data();
  const auto options = mrsns::ultrasound::segmentationOptionsFrom(*d.config.segmentation);
  for (auto _ : state) {
    const auto s = mrsns::ultrasound::segmentCalibrationSequence(
        d.calibration, d.config.requirePhantom(), options, "ProbeToReference", static_cast<unsigned>(state.range(0)));
    benchmark::DoNotOptimize(s.frames.data());
  }
  state.SetItemsProcessed(state.iterations() * static_cast<std::int64_t>(d.calibration.frames.size()));
}
BENCHMARK(BM_Segmentation)->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond)->UseRealTime();

}  // namespace

BENCHMARK_MAIN();
