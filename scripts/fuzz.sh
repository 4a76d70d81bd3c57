#!/usr/bin/env bash
# Builds the libFuzzer targets with clang (build-fuzz/) and runs each
# (the sequence-file header parser, the OpenIGTLink decoder) for SECONDS
# (default 30) on a scratch copy of its seed corpus, so the checked-in seeds
# never change. Prints the executions
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
targets=("fuzz_sequence_header:sequence_header" "fuzz_igtlink_decoder:igtlink")
names=()
for t in "${targets[@]}"; do names+=("${t%%:*}"); done
ninja -C "$fuzz_build" "${names[@]}"

work="$(mktemp -d)"
trap 'rm -rf "$work"' EXIT
mkdir -p "$fuzz_build/findings"
failed=0
for t in "${targets[@]}"; do
  target="${t%%:*}"
  corpus="${t##*:}"
  cp -r "$MRSNS_ROOT/tests/fuzz/corpus/$corpus" "$work/$corpus"
  log="$work/$target.log"
  status=0
  "$fuzz_build/tests/fuzz/$target" "$work/$corpus" -max_total_time="$seconds" -rss_limit_mb=2048 \
    -max_len=65536 -print_final_stats=1 -artifact_prefix="$fuzz_build/findings/$target-" >"$log" 2>&1 || status=$?
  runs=$(grep -oE 'stat::number_of_executed_units: *[0-9]+' "$log" | grep -oE '[0-9]+$' || echo 0)
  elapsed=$(grep -oE 'Done [0-9]+ runs in [0-9]+ second' "$log" | grep -oE 'in [0-9]+' | grep -oE '[0-9]+' || echo "$seconds")
  [ "${elapsed:-0}" -gt 0 ] || elapsed="$seconds"
  echo "$target: $runs executions in ${elapsed} s ($(( runs / elapsed )) exec/s)"
  if [ "$status" -ne 0 ]; then
    tail -n 40 "$log"
    echo "$target: FINDING (exit $status), reproducer in $fuzz_build/findings/" >&2
    failed=1
  fi
done
exit "$failed"
