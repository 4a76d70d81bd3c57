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
mrsns_build
phase_end

[ "$run_demo" = 1 ] || exit 0

phase_start "main job"
# Until the phantom trial exists (workstation issue), the main job runs the
# most complete chain available on the sample data, each step a CLI verb.
cli="$MRSNS_BUILD_DIR/app/cli/mrsns-cli"
plus="$MRSNS_DATA_DIR/plus"
out="$MRSNS_BUILD_DIR/demo"
rm -rf "$out"
mkdir -p "$out"
step() { echo; echo "---- mrsns-cli $*"; "$cli" "$@"; }

# 1. Patient model: the bundled cervical phantom (needs no shared data).
step make-phantom --output "$out/phantom"
step segment "$out/phantom/phantom_ct.nrrd" --output "$out/segmentation"
step find-fiducials --screws "$out/phantom/fiducial_screws.stl" --bone "$out/segmentation/bone.stl" --count 8 \
  --output "$out/fiducials_found.mrk.json"
step plan-check --paths "$out/phantom/screw_paths.mrk.json" --surface "$out/phantom/carotid_artery.stl"
# 2. Soft-tissue deformation: the simulated carotid protocol of paper 001.
step deform-trial --cases 2

# 3. Real recordings (the shared data set): tracked ultrasound.
recording="$plus/fCal_Test_Calibration_3NWires.igs.mha"
if [ ! -f "$recording" ]; then
  echo
  echo "The PLUS sample recording was not found at $recording: skipping the ultrasound steps."
  echo "Set MRSNS_DATA_DIR to the shared data folder (see README.md) to run them."
else
  step info "$recording"
  step convert "$recording" "$out/fCal_Test_Calibration_3NWires.seq.nrrd"
  step calibrate-us --config "$plus/PlusDeviceSet_fCal_Sim_SpatialCalibration_1.2.xml" \
    --calibration "$recording" --validation "$plus/fCal_Test_Validation_3NWires.igs.mha" \
    --reference-results "$plus/FreehandCalibration3NWires.results.xml"
fi
echo
echo "Main job done; outputs in $out"
phase_end
