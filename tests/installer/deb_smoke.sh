#!/bin/sh
# Unpacks the .deb cpack made into a scratch root and runs the installed
# mrsns-cli: --version, the sample session found under share/mrsns, the WebXR
# client's page served by the installed `serve` and loaded in headless
# chromium, a short phantom trial whose report has the figures.
# Usage: deb_smoke.sh DEB_DIR VERSION
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
         usr/share/icons/hicolor/scalable/apps/mrsns.svg usr/share/mrsns/webxr/index.html \
         usr/share/mrsns/webxr/client.js usr/share/mrsns/webxr/style.css; do
  [ -e "$root/$f" ] || { echo "the package lacks /$f" >&2; exit 1; }
done
if grep -q '^Exec=mrsns' "$root/usr/share/applications/mrsns.desktop" && [ ! -e "$root/usr/bin/mrsns" ]; then
  echo "note: the desktop entry runs mrsns, which this build did not include (app/gui not built)"
fi
# The page's three.js is Debian's libjs-three, a dependency of the package.
dpkg-deb -f "$deb" Depends | grep -q 'libjs-three' || { echo "the package does not depend on libjs-three" >&2; exit 1; }
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

# The WebXR client from the installed package: its serve, its page, chromium showing the models. In real time:
# chromium's --virtual-time-budget runs the page's clock ahead of the server's (a WebSocket does not hold it), so
# under load the page was dumped before it had paired. The serve's own report says what the page did: it paired
# and reported drawing both models at their poses (the page's "shown" messages, sent after a frame is drawn).
if command -v chromium >/dev/null; then
  run=$deb_dir/run
  "$cli" make-phantom --output "$run/phantom" --spacing 1.5 --json >/dev/null
  "$cli" serve --port 0 --models "$run/phantom/C5.stl" "$run/phantom/carotid_artery.stl" --webxr-port 0 \
    --webxr-code 135790 --webxr-tls-dir "$run/tls" --duration 25 --json >"$run/serve.json" 2>"$run/serve.err" &
  serve_pid=$!
  url=""
  for _ in $(seq 1 100); do
    url=$(sed -n 's/.*WebXR client at \(https:[^ ]*\).*/\1/p' "$run/serve.err")
    [ -n "$url" ] && break
    sleep 0.1
  done
  [ -n "$url" ] || { kill "$serve_pid"; echo "the installed serve printed no WebXR address:" >&2; cat "$run/serve.err" >&2; exit 1; }
  chromium --headless=new --no-sandbox --ignore-certificate-errors --use-angle=swiftshader --enable-unsafe-swiftshader \
    --user-data-dir="$run/chromium" --remote-debugging-port=0 "${url}?code=135790" \
    >"$run/chromium.out" 2>"$run/chromium.log" &
  chromium_pid=$!
  wait "$serve_pid" || { kill "$chromium_pid" 2>/dev/null; echo "the installed serve failed:" >&2; cat "$run/serve.err" >&2; exit 1; }
  kill "$chromium_pid" 2>/dev/null || true
  wait "$chromium_pid" 2>/dev/null || true
  number() { sed -n "s/.*\"$1\": *\([0-9][0-9]*\).*/\1/p" "$run/serve.json" | head -n 1; }
  paired=$(number pages_paired)
  shown=$(number models_shown)
  if [ "${paired:-0}" -lt 1 ] || [ "${shown:-0}" -ne 2 ]; then
    echo "the WebXR page served by the installed package did not pair and draw its 2 models" \
      "(pages paired: ${paired:-?}, models drawn: ${shown:-?}); serve's report:" >&2
    cat "$run/serve.json" >&2
    grep -v dbus "$run/chromium.log" | tail -n 20 >&2
    exit 1
  fi
  echo "WebXR page from the installed package: paired, drew its $shown models at their poses"
elif [ "${CI:-}" = true ] || [ "${CI:-}" = 1 ]; then
  echo "chromium is not installed (scripts/debian-packages.txt): the WebXR page cannot be tried" >&2
  exit 1
else
  echo "note: chromium not installed, the WebXR page from the package is not tried"
fi

"$cli" trial --out "$deb_dir/run/trial" --navigation-s 0.6 --deformation-cases 1 --json >"$deb_dir/run/trial.json"
for key in '"us-spatial-calibration"' '"registration"' '"robot-placement"' '"navigation"'; do
  grep -q "$key" "$deb_dir/run/trial/report.json" || { echo "report.json lacks $key" >&2; exit 1; }
done
[ -s "$deb_dir/run/trial/index.html" ] || { echo "no index.html" >&2; exit 1; }
echo "installed package OK: $deb"
