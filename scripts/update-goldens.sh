#!/usr/bin/env bash
# Rewrites the golden images screenshots/NAME.png from screenshots/goldens.txt with the current
# build's greybench-snapshot (building it first). Look at every changed image before committing.
#
#   scripts/update-goldens.sh [NAME...]     (default: all)
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$root"
if [[ ! -f build/build.ninja ]]; then
  cmake -S . -B build -G Ninja -DCMAKE_BUILD_TYPE=Release ${GREYBENCH_CMAKE_ARGS:-}
fi
cmake --build build -j "$(nproc)" --target greybench-snapshot
snapshot="$root/build/app/greybench-snapshot"

want=" $* "
while read -r name project view flags; do
  [[ -z $name || $name == \#* ]] && continue
  [[ $# -gt 0 && $want != *" $name "* ]] && continue
  echo "screenshots/$name.png: $project, view $view ${flags:-}"
  # shellcheck disable=SC2086  # flags is a list of options
  "$snapshot" --project "$project" --view "$view" ${flags:-} --out "screenshots/$name.png"
done < screenshots/goldens.txt
git -C "$root" status --short screenshots/
