#!/usr/bin/env bash
# Regenerates every figure of docs/case-study.md and docs/case-study-mvem.md into docs/figures/,
# each rendered by the workbench itself (greybench-snapshot, offscreen) from a bundled project.
#   scripts/render-figures.sh [BUILD_DIR]      (default: build; needs greybench-snapshot built)
# Deterministic: the same build and inputs give the same PNG bytes.
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
build="${1:-$root/build}"
snapshot="$build/app/greybench-snapshot"
project="$root/assets/projects/case_study.json"
out="$root/docs/figures"
[[ -x "$snapshot" ]] || { echo "render-figures: $snapshot not found (build it first)" >&2; exit 2; }
mkdir -p "$out"

render() {  # NAME VIEW WIDTH HEIGHT [--estimate]
  local name="$1" view="$2" width="$3" height="$4"; shift 4
  echo "render-figures: $name ($view view)"
  "$snapshot" --project "$project" --view "$view" --width "$width" --height "$height" "$@" \
    --out "$out/$name.png"
}

# Table 2, Fig. 3 (the delay against speed, with Δt = c / n) and Fig. 4 (X against the throttle
# angle α, with the least-squares line): the operating points view after the sweep of the six
# points named in the project's "operating_points" key.
render operating-points operating-points 1600 900 --estimate

# Fig. 5 (one-step predictions of 1/λ with the measurements) and Fig. 6 (of the engine speed N):
# the predictions view after the fit, on a stretch of the record short enough to tell the curves
# apart, as the paper does.
render fig5-predictions-fuel predictions 1280 720 --estimate --time 20:30
project="$root/assets/projects/crankshaft.json"
render fig6-predictions-crankshaft predictions 1280 900 --estimate --time 40:70

# The engine over its operating range (docs/case-study-mvem.md): the per-point linear fits of
# the six fuel records beside the bundled nonlinear fit linearised at each point.
project="$root/assets/projects/engine_mvem.json"
render engine-operating-points operating-points 1600 1200 --estimate
