#!/usr/bin/env bash
# Render a report's index.html in headless Chromium (Debian package `chromium`) to a PNG,
# to check that the page reads well in a real browser. Usage:
#   scripts/screenshot-report.sh REPORT_DIR OUT.png [WIDTHxHEIGHT]
# PAGE=datasheet.html renders another page of the folder (a `datasheet` output).
set -euo pipefail
dir=$(cd "$1" && pwd)
out=$2
size=${3:-1200,2400}
command -v chromium >/dev/null || { echo "needs chromium: apt-get install -y chromium" >&2; exit 2; }
profile=$(mktemp -d)
trap 'rm -rf "$profile"' EXIT
chromium --headless --no-sandbox --disable-gpu --disable-quic --no-first-run \
  --disable-background-networking --disable-component-update --disable-sync \
  --user-data-dir="$profile" --hide-scrollbars --window-size="${size/x/,}" \
  --screenshot="$out" "file://$dir/${PAGE:-index.html}" 2>/dev/null
test -s "$out" && echo "wrote $out"
