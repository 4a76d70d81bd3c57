// RTDE data-package encode and decode of the exhaustive output recipe (every documented output and register,
// the shared data set's exhaustive_rtde_output_recipe.txt), and of the 7-field state recipe UrRtdeArm uses.
// A 500 Hz controller leaves 2 ms per cycle: the codec must be a negligible part of it.
#include <benchmark/benchmark.h>

#include <fstream>
#include <sstream>

#include "mrsns/robot/rtde_protocol.h"

using namespace mrsns::robot::rtde;

namespace {

Recipe exhaustiveRecipe() {
  std::ifstream in(std::string(MRSNS_BENCH_DATA_DIR) + "/robot/exhaustive_rtde_output_recipe.txt");
  std::stringstream s;
  s << in.rdbuf();
  Recipe r = parseRecipeText(s.str(), "exhaustive_rtde_output_recipe.txt");
  r.id = 1;
  return r;
}

Recipe stateRecipe() {
  Recipe r = recipeFromNames(
      {"timestamp", "actual_q", "actual_qd", "actual_TCP_pose", "actual_TCP_speed", "robot_mode", "safety_mode"});
  r.id = 1;
  return r;
}

void encode(benchmark::State& state, const Recipe& recipe) {
  std::vector<Value> values;
  for (const auto& f : recipe.fields) values.push_back(zeroValue(f.type));
  for (auto _ : state) {
    auto bytes = encodeDataPackage(recipe, values);
    benchmark::DoNotOptimize(bytes.data());
  }
  state.counters["fields"] = static_cast<double>(recipe.fields.size());
  state.counters["bytes"] = static_cast<double>(recipe.payloadSize() + 4);
}

void decode(benchmark::State& state, const Recipe& recipe) {
  std::vector<Value> values;
  for (const auto& f : recipe.fields) values.push_back(zeroValue(f.type));
  const auto bytes = encodeDataPackage(recipe, values);
  for (auto _ : state) {
    auto decoded = decodeDataPackage(decodePackage(bytes), recipe);
    benchmark::DoNotOptimize(decoded.data());
  }
  state.counters["fields"] = static_cast<double>(recipe.fields.size());
}

void BM_EncodeExhaustive(benchmark::State& s) {
  encode(s, exhaustiveRecipe());
}
void BM_DecodeExhaustive(benchmark::State& s) {
  decode(s, exhaustiveRecipe());
}
void BM_EncodeState(benchmark::State& s) {
  encode(s, stateRecipe());
}
void BM_DecodeState(benchmark::State& s) {
  decode(s, stateRecipe());
}

}  // namespace

BENCHMARK(BM_EncodeExhaustive);
BENCHMARK(BM_DecodeExhaustive);
BENCHMARK(BM_EncodeState);
BENCHMARK(BM_DecodeState);
BENCHMARK_MAIN();
