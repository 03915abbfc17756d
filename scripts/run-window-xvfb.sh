#!/usr/bin/env bash
# Runs the real greybench window (GLFW + OpenGL 3) on a virtual X display and saves what it
# shows: greybench draws a few frames once the project is loaded, writes the PNG and exits.
#
#   scripts/run-window-xvfb.sh [--exe PATH] [--frames N] [--size WxH] [--view-image WxH]
#                              OUT.png [PROJECT.json]
#
# --exe         the greybench executable (default: build/app/greybench under the source tree)
# --frames      frames drawn before the screenshot (default 5)
# --size        window size in pixels (default 1440x900)
# --view-image  write File › Export › Image of the view at WxH instead of the window's pixels
# Without PROJECT.json greybench opens the bundled case study (or an empty workbench).
# Needs xvfb-run (Debian package xvfb); Mesa renders in software, so no GPU is needed.
set -euo pipefail

root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
exe="$root/build/app/greybench"
frames=5
size="1440x900"
view_image=""

usage() {
  sed -n '5,12p' "${BASH_SOURCE[0]}" | sed 's/^# \{0,1\}//' >&2
  exit 2
}

while [[ $# -gt 0 ]]; do
  case "$1" in
    --exe) exe="$2"; shift 2 ;;
    --frames) frames="$2"; shift 2 ;;
    --size) size="$2"; shift 2 ;;
    --view-image) view_image="$2"; shift 2 ;;
    -h|--help) usage ;;
    --*) echo "run-window-xvfb.sh: error: unknown option '$1'" >&2; usage ;;
    *) break ;;
  esac
done
[[ $# -ge 1 && $# -le 2 ]] || usage
out="$1"
project="${2:-}"

if ! command -v xvfb-run >/dev/null 2>&1; then
  echo "run-window-xvfb.sh: error: xvfb-run not found (apt-get install xvfb)" >&2
  exit 2
fi
if [[ ! -x "$exe" ]]; then
  echo "run-window-xvfb.sh: error: $exe is not an executable (build greybench or pass --exe)" >&2
  exit 2
fi
if [[ ! "$size" =~ ^([0-9]+)x([0-9]+)$ ]]; then
  echo "run-window-xvfb.sh: error: --size '$size': expected WxH, e.g. 1440x900" >&2
  exit 2
fi
width="${BASH_REMATCH[1]}"
height="${BASH_REMATCH[2]}"

# The screen is a little larger than the window so the window manager-less server never clips it.
screen="$((width + 64))x$((height + 64))x24"
args=(--width "$width" --height "$height" --screenshot "$out" --frames "$frames")
[[ -n "$view_image" ]] && args+=(--view-image "$view_image")
[[ -n "$project" ]] && args=("$project" "${args[@]}")

LIBGL_ALWAYS_SOFTWARE=1 timeout 300 \
  xvfb-run --auto-servernum --server-args="-screen 0 $screen -nolisten tcp" \
  "$exe" "${args[@]}"
echo "run-window-xvfb.sh: wrote $out"
