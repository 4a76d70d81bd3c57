#!/usr/bin/env bash
# Builds and runs every benchmark program (tests/benchmarks), writing JSON
# results to build/benchmarks/. Extra arguments go to each program, e.g.
#   scripts/bench.sh --benchmark_repetitions=5
set -euo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/common.sh"
mrsns_build
mkdir -p "$MRSNS_BUILD_DIR/benchmarks"
for b in "$MRSNS_BUILD_DIR"/tests/benchmarks/mrsns_bench_*; do
  [ -x "$b" ] || continue
  name=$(basename "$b")
  echo "== $name"
  "$b" --benchmark_out="$MRSNS_BUILD_DIR/benchmarks/$name.json" --benchmark_out_format=json "$@"
done
