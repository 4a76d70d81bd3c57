#!/usr/bin/env bash
# Builds the libFuzzer targets with clang (build-fuzz/) and runs the
# sequence-header fuzzer for SECONDS (default 30) on a scratch copy of its
# seed corpus, so the checked-in seeds never change. Prints the executions
# and their rate; exits non-zero when the fuzzer finds a crash, leak or
# sanitizer error (the reproducer is left in build-fuzz/findings/).
#   scripts/fuzz.sh [SECONDS]
set -euo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/common.sh"
seconds="${1:-30}"
fuzz_build="${MRSNS_FUZZ_BUILD_DIR:-$MRSNS_ROOT/build-fuzz}"
if [ ! -f "$fuzz_build/build.ninja" ]; then
  CC=clang-14 CXX=clang++-14 cmake -S "$MRSNS_ROOT" -B "$fuzz_build" -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo \
    -DMRSNS_BUILD_FUZZERS=ON >/dev/null
fi
ninja -C "$fuzz_build" fuzz_sequence_header

work="$(mktemp -d)"
trap 'rm -rf "$work"' EXIT
cp -r "$MRSNS_ROOT/tests/fuzz/corpus/sequence_header" "$work/corpus"
mkdir -p "$fuzz_build/findings"
log="$work/fuzz.log"
status=0
"$fuzz_build/tests/fuzz/fuzz_sequence_header" "$work/corpus" -max_total_time="$seconds" -rss_limit_mb=2048 \
  -max_len=65536 -print_final_stats=1 -artifact_prefix="$fuzz_build/findings/" >"$log" 2>&1 || status=$?
runs=$(grep -oE 'stat::number_of_executed_units: *[0-9]+' "$log" | grep -oE '[0-9]+$' || echo 0)
elapsed=$(grep -oE 'Done [0-9]+ runs in [0-9]+ second' "$log" | grep -oE 'in [0-9]+' | grep -oE '[0-9]+' || echo "$seconds")
[ "${elapsed:-0}" -gt 0 ] || elapsed="$seconds"
echo "fuzz_sequence_header: $runs executions in ${elapsed} s ($(( runs / elapsed )) exec/s)"
if [ "$status" -ne 0 ]; then
  tail -n 40 "$log"
  echo "fuzz_sequence_header: FINDING (exit $status), reproducer in $fuzz_build/findings/" >&2
  exit 1
fi
