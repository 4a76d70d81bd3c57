#!/usr/bin/env bash
# Runs the whole MR-SNS test suite: builds if needed, runs the fuzzer briefly
# (when clang-14 with libFuzzer is present), then every CTest test under
# xvfb-run. Extra arguments go to ctest (e.g. -R '^core\.').
set -euo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/common.sh"

phase_start "build"
mrsns_build
phase_end

if [ $# -eq 0 ] && command -v clang++-14 >/dev/null 2>&1; then
  phase_start "fuzz (short run)"
  "$MRSNS_ROOT/scripts/fuzz.sh" "${MRSNS_FUZZ_SECONDS:-30}"
  phase_end
fi

phase_start "interop peers (pyigtl, ur_rtde in $MRSNS_BUILD_DIR/venv)"
# Without network or pip the Python interop tests skip; they never fail the suite.
# ur-rtde 1.6.5 installs as a manylinux wheel (checked: CPython 3.11, x86_64); where
# pip has no wheel for the Python, its test is skipped, not built from source.
if [ ! -x "$MRSNS_BUILD_DIR/venv/bin/python" ]; then
  python3 -m venv "$MRSNS_BUILD_DIR/venv" >/dev/null 2>&1 || echo "no venv: the Python interop tests will be skipped"
fi
if [ -x "$MRSNS_BUILD_DIR/venv/bin/pip" ]; then
  "$MRSNS_BUILD_DIR/venv/bin/pip" install -q --disable-pip-version-check pyigtl==0.3.4 >/dev/null 2>&1 ||
    echo "pip install pyigtl==0.3.4 failed: the pyigtl interop tests will be skipped"
  "$MRSNS_BUILD_DIR/venv/bin/pip" install -q --disable-pip-version-check --only-binary ur-rtde ur-rtde==1.6.5 \
    >/dev/null 2>&1 || echo "pip install ur-rtde==1.6.5 failed: the ur_rtde interop test will be skipped"
fi
phase_end

phase_start "tests"
xvfb-run -a ctest --test-dir "$MRSNS_BUILD_DIR" --output-on-failure -j "$(nproc)" "$@"
phase_end
