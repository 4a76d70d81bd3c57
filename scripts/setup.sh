#!/usr/bin/env bash
# Installs what is missing (Debian 12 packages), builds MR-SNS, and runs the
# main job on the sample data. Options:
#   --no-demo   install and build only
set -euo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/common.sh"

run_demo=1
for arg in "$@"; do
  case "$arg" in
    --no-demo) run_demo=0 ;;
    -h|--help) sed -n '2,5p' "$0"; exit 0 ;;
    *) echo "setup.sh: unknown option '$arg' (try --help)" >&2; exit 2 ;;
  esac
done

phase_start "packages"
mapfile -t packages < <(grep -v '^\s*#' "$MRSNS_ROOT/scripts/debian-packages.txt" | sed '/^\s*$/d')
missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -gt 0 ]; then
  echo "installing ${#missing[@]} missing packages: ${missing[*]}"
  SUDO=""
  [ "$(id -u)" -ne 0 ] && SUDO="sudo"
  $SUDO apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y --no-install-recommends "${missing[@]}"
else
  echo "all ${#packages[@]} packages present"
fi
phase_end

phase_start "build"
# The programs only; scripts/test.sh builds the test programs on top.
MRSNS_BUILD_TARGET=mrsns_programs mrsns_build
phase_end

[ "$run_demo" = 1 ] || exit 0

phase_start "main job"
# The whole phantom trial (workstation issue): every workflow step of paper
# 001 on bundled data (simulated tracker, robot and HMD, the PLUS recording
# for the ultrasound calibrations, the generated cervical phantom), with a
# report folder: index.html beside the papers' figures, report.json, session.
cli="$MRSNS_BUILD_DIR/app/cli/mrsns-cli"
out="$MRSNS_BUILD_DIR/trial"
rm -rf "$out"
# The report's snapshots need an X display; without one, a virtual one.
display=()
if [ -z "${DISPLAY:-}" ] && command -v xvfb-run >/dev/null; then display=(xvfb-run -a); fi
echo "---- ${display[*]} mrsns-cli trial --out $out"
MRSNS_DATA_DIR="$MRSNS_DATA_DIR" "${display[@]}" "$cli" trial --out "$out"
echo
echo "Main job done; report in $out/index.html"
phase_end
