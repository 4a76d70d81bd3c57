#!/bin/sh
# Unpacks the .deb cpack made into a scratch root and runs the installed
# mrsns-cli: --version, the sample session found under share/mrsns, a short
# phantom trial whose report has the figures. Usage: deb_smoke.sh DEB_DIR VERSION
set -eu
deb_dir=$1
version=$2
deb=$(ls "$deb_dir"/mrsns_*.deb | head -n 1)
[ -f "$deb" ] || { echo "no mrsns_*.deb in $deb_dir" >&2; exit 1; }
root=$deb_dir/root
rm -rf "$root" "$deb_dir/run"
mkdir -p "$root" "$deb_dir/run"
dpkg -x "$deb" "$root"
for f in usr/bin/mrsns-cli usr/share/mrsns/sample_session/session.json usr/share/applications/mrsns.desktop \
         usr/share/icons/hicolor/scalable/apps/mrsns.svg; do
  [ -e "$root/$f" ] || { echo "the package lacks /$f" >&2; exit 1; }
done
if grep -q '^Exec=mrsns' "$root/usr/share/applications/mrsns.desktop" && [ ! -e "$root/usr/bin/mrsns" ]; then
  echo "note: the desktop entry runs mrsns, which this build did not include (app/gui not built)"
fi
cli=$root/usr/bin/mrsns-cli
out=$("$cli" --version)
echo "$out"
case "$out" in *"$version"*) ;; *) echo "--version printed '$out', expected $version" >&2; exit 1 ;; esac
# The installed copy must find the sample session in its own share/ folder,
# not in the source tree.
"$cli" session sample "$deb_dir/run/session" --json >"$deb_dir/run/sample.json"
grep -q "\"sample\": \"$root/usr/share/mrsns/sample_session\"" "$deb_dir/run/sample.json" || {
  echo "the installed mrsns-cli did not use its own sample session:" >&2
  cat "$deb_dir/run/sample.json" >&2
  exit 1
}
"$cli" trial --out "$deb_dir/run/trial" --navigation-s 0.6 --deformation-cases 1 --json >"$deb_dir/run/trial.json"
for key in '"us-spatial-calibration"' '"registration"' '"robot-placement"' '"navigation"'; do
  grep -q "$key" "$deb_dir/run/trial/report.json" || { echo "report.json lacks $key" >&2; exit 1; }
done
[ -s "$deb_dir/run/trial/index.html" ] || { echo "no index.html" >&2; exit 1; }
echo "installed package OK: $deb"
