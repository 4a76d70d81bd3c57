#!/usr/bin/env bash
# Builds and runs every benchmark program (tests/benchmarks), writing JSON
# results to build/benchmarks/. Extra arguments go to each program, e.g.
#   scripts/bench.sh --benchmark_repetitions=5
set -euo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/common.sh"
# Benchmarks are off in the default build (setup.sh); one build with them on.
mrsns_build -DMRSNS_BUILD_BENCHMARKS=ON
# The peers that are Python packages (the ICP benchmark's Open3D) live in the
# test venv; without network the benchmark says so and skips that peer.
if [ ! -x "$MRSNS_BUILD_DIR/venv/bin/python" ]; then
  python3 -m venv "$MRSNS_BUILD_DIR/venv" >/dev/null 2>&1 || echo "no venv: the Open3D peer will be skipped"
fi
if [ -x "$MRSNS_BUILD_DIR/venv/bin/pip" ]; then
  "$MRSNS_BUILD_DIR/venv/bin/pip" install -q --disable-pip-version-check --only-binary open3d-cpu open3d-cpu==0.20.0 \
    >/dev/null 2>&1 || echo "pip install open3d-cpu==0.20.0 failed: the Open3D peer will be skipped"
fi
mkdir -p "$MRSNS_BUILD_DIR/benchmarks"
for b in "$MRSNS_BUILD_DIR"/tests/benchmarks/mrsns_bench_*; do
  [ -x "$b" ] || continue
  name=$(basename "$b")
  echo "== $name"
  "$b" --benchmark_out="$MRSNS_BUILD_DIR/benchmarks/$name.json" --benchmark_out_format=json "$@"
done
