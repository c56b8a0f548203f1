#!/usr/bin/env bash
# Screenshots of a job's report.html in headless Chromium (Debian's chromium
# package, installed with apt-get when missing; run as root then), full page,
# at 1024 and 1600 px wide: the layout check of docs/jobs.md.
#
#   tools/report_screenshots.sh [REPORT_HTML [OUT_DIR]]
#
# REPORT_HTML defaults to out/report.html of the README's main job
# (tools/setup/main_job.sh), which is run first when that file is missing.
# OUT_DIR defaults to docs/results; the PNGs are report-1024.png and
# report-1600.png. The page height is measured by Chromium itself on a
# temporary copy of the page with one line of script added (the report has
# none). Exit code: non-zero when a step fails.
set -euo pipefail
cd "$(dirname "$0")/.."
REPORT=${1:-out/report.html}
OUT_DIR=${2:-docs/results}

if ! command -v chromium >/dev/null; then
  if [[ $(id -u) != 0 ]]; then
    echo "chromium is missing; run as root to install it (apt-get install chromium)" >&2
    exit 1
  fi
  export DEBIAN_FRONTEND=noninteractive
  apt-get update -qq
  apt-get install -y -qq --no-install-recommends chromium fonts-dejavu-core
fi
if [[ ! -f "$REPORT" ]]; then
  if [[ "$REPORT" != out/report.html ]]; then
    echo "no such report: $REPORT" >&2
    exit 1
  fi
  bash tools/setup/main_job.sh
fi

mkdir -p "$OUT_DIR"
scratch=$(mktemp -d)
trap 'rm -rf "$scratch"' EXIT
report_abs=$(realpath "$REPORT")
# Chromium runs as root here only with --no-sandbox; no network is needed
# (the page is self-contained) and none is used.
chrome=(chromium --headless --no-sandbox --disable-gpu --hide-scrollbars
        --force-device-scale-factor=1 --user-data-dir="$scratch/profile")
cp "$report_abs" "$scratch/measure.html"
echo '<script>document.title = "height=" + document.documentElement.scrollHeight;</script>' \
  >> "$scratch/measure.html"
for width in 1024 1600; do
  height=$("${chrome[@]}" --window-size="$width,1000" --dump-dom "file://$scratch/measure.html" \
             2>/dev/null | sed -n 's/.*<title>height=\([0-9]*\)<\/title>.*/\1/p')
  if [[ -z "$height" ]]; then
    echo "chromium did not report the page height at $width px" >&2
    exit 1
  fi
  png="$OUT_DIR/report-$width.png"
  "${chrome[@]}" --window-size="$width,$height" --screenshot="$scratch/shot.png" \
    "file://$report_abs" 2>/dev/null
  mv "$scratch/shot.png" "$png"
  echo "$png: ${width} x ${height} px"
done
