#!/bin/sh
# Runs a Python interop script whose peer library comes from PyPI (pyigtl,
# ur_rtde) with the virtualenv Python that scripts/test.sh fills; exits 77
# (CTest: skipped) with the reason when that Python or the peer is missing.
# Everything else (mrsns-sim missing, a wrong message) is the script's own
# pass or fail.
# usage: run_python_peer.sh PYTHON MODULE PIP_REQUIREMENT SCRIPT [ARGS...]
python="${MRSNS_PYTHON:-$1}"
module="$2"
requirement="$3"
script="$4"
shift 4
if [ -z "$python" ] || [ ! -x "$python" ]; then
  echo "SKIP: no virtualenv Python at '${python}' (run scripts/test.sh, which creates build/venv, or set MRSNS_PYTHON)"
  exit 77
fi
if ! "$python" -c "import $module" >/dev/null 2>&1; then
  echo "SKIP: '$python' cannot import $module (pip install $requirement in that virtualenv)"
  exit 77
fi
exec "$python" "$script" "$@"
