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

phase_start() { PHASE_NAME="$1"; PHASE_T0=$(date +%s); echo "== $1"; }
phase_end() { echo "== $PHASE_NAME: $(( $(date +%s) - PHASE_T0 )) s"; }

# Configures (once) and builds the project in $MRSNS_BUILD_DIR.
mrsns_build() {
  local werror=OFF
  [ "${CI:-}" = "true" ] && werror=ON
  if [ ! -f "$MRSNS_BUILD_DIR/build.ninja" ]; then
    cmake -S "$MRSNS_ROOT" -B "$MRSNS_BUILD_DIR" -G Ninja -DCMAKE_BUILD_TYPE=Release \
      -DMRSNS_WERROR="$werror" -DMRSNS_DATA_DIR="$MRSNS_DATA_DIR"
  fi
  cmake --build "$MRSNS_BUILD_DIR" -j "$(nproc)"
}
