#!/bin/sh
# Runs pyigtl_receive.py against mrsns-cli serve with a Python that has pyigtl;
# exits 77 (CTest: skipped) with the reason when there is none.
# usage: run_pyigtl.sh MRSNS_CLI SCRIPT [PYTHON]
cli="$1"
script="$2"
python="${MRSNS_PYTHON:-$3}"
if [ -z "$python" ] || [ ! -x "$python" ]; then
  echo "SKIP: no virtualenv Python with pyigtl at '${python}' (run scripts/test.sh, which creates build/venv, or set MRSNS_PYTHON)"
  exit 77
fi
if ! "$python" -c "import pyigtl" >/dev/null 2>&1; then
  echo "SKIP: '$python' cannot import pyigtl (pip install pyigtl==0.3.4 in that virtualenv)"
  exit 77
fi
exec "$python" "$script" --cli "$cli"
