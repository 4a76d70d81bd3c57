# Shared settings of the MR-SNS scripts (sourced, not run).
MRSNS_ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
MRSNS_BUILD_DIR="${MRSNS_BUILD_DIR:-$MRSNS_ROOT/build}"
if [ -z "${MRSNS_DATA_DIR:-}" ]; then
  MRSNS_DATA_DIR="$(cd "$MRSNS_ROOT/.." && pwd)/shared/data"
fi
export MRSNS_DATA_DIR
export CCACHE_DIR="${CCACHE_DIR:-$HOME/.cache/ccache}"
# Paths relative to the checkout, so a fresh clone elsewhere (CI) hits the cache.
export CCACHE_BASEDIR="${CCACHE_BASEDIR:-$MRSNS_ROOT}"
# Hash the compiler's own dependency list (-MD) instead of running the
# preprocessor a second time on every miss: about 0.4 s per translation unit
# of a cold build. (CCACHE_NODEPEND=1 turns it off.)
[ -n "${CCACHE_NODEPEND:-}" ] || export CCACHE_DEPEND=1

phase_start() { PHASE_NAME="$1"; PHASE_T0=$(date +%s); echo "== $1"; }
phase_end() { echo "== $PHASE_NAME: $(( $(date +%s) - PHASE_T0 )) s"; }

# Configures (once) and builds the project in $MRSNS_BUILD_DIR. Arguments are
# CMake cache settings applied before the build (bench.sh: the benchmarks).
# MRSNS_BUILD_TARGET names one target to build instead of all (setup.sh:
# mrsns_programs, the programs without the test suite).
mrsns_build() {
  local werror=OFF
  [ "${CI:-}" = "true" ] && werror=ON
  if [ ! -f "$MRSNS_BUILD_DIR/build.ninja" ]; then
    cmake -S "$MRSNS_ROOT" -B "$MRSNS_BUILD_DIR" -G Ninja -DCMAKE_BUILD_TYPE=Release \
      -DMRSNS_WERROR="$werror" -DMRSNS_DATA_DIR="$MRSNS_DATA_DIR" "$@"
  elif [ $# -gt 0 ]; then
    cmake -S "$MRSNS_ROOT" -B "$MRSNS_BUILD_DIR" "$@" >/dev/null
  fi
  local before
  before=$(ccache_counts)
  local target=()
  [ -n "${MRSNS_BUILD_TARGET:-}" ] && target=(--target "$MRSNS_BUILD_TARGET")
  cmake --build "$MRSNS_BUILD_DIR" -j "$(nproc)" "${target[@]}"
  # Whether this build was cold (every compilation a cache miss) or warm,
  # so the build time printed by phase_end can be read.
  if [ -n "$before" ]; then
    read -r hits0 misses0 <<<"$before"
    read -r hits1 misses1 <<<"$(ccache_counts)"
    echo "ccache: $((hits1 - hits0)) hits, $((misses1 - misses0)) misses in this build"
  fi
}

# "hits misses" of ccache so far (empty without ccache).
ccache_counts() {
  command -v ccache >/dev/null || return 0
  ccache --print-stats 2>/dev/null | awk '
    $1 == "direct_cache_hit" || $1 == "preprocessed_cache_hit" { h += $2 }
    $1 == "cache_miss" { m += $2 }
    END { print h + 0, m + 0 }'
}
