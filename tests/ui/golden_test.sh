#!/usr/bin/env bash
# Renders one view with greybench-snapshot and compares it with its golden image.
#
#   golden_test.sh SNAPSHOT_EXE PNG_DIFF_EXE SOURCE_DIR OUT_DIR NAME PROJECT VIEW [--estimate]
#   golden_test.sh --rendered PNG_DIFF_EXE SOURCE_DIR OUT_DIR NAME
#   golden_test.sh --render-estimated SNAPSHOT_EXE SOURCE_DIR OUT_DIR PROJECT NAME VIEW [NAME VIEW ...]
#
# The golden is SOURCE_DIR/screenshots/NAME.png (screenshots/goldens.txt lists them;
# scripts/update-goldens.sh rewrites them). On a mismatch the rendering and an image of the
# differences are left in OUT_DIR. Exit 0 match, 1 mismatch or failure.
# The second form compares OUT_DIR/NAME.png, which a fixture rendered before: the third form,
# which renders every estimated view as OUT_DIR/NAME.png in one greybench-snapshot run with
# --estimate (one estimation for all of them; tests/ui/CMakeLists.txt).
set -uo pipefail

if [[ ${1:-} == --render-estimated ]]; then
  snapshot="$2"; source_dir="$3"; out="$4"; project="$5"
  shift 5
  mkdir -p "$out"
  shots=()
  while [[ $# -ge 2 ]]; do
    rm -f "$out/$1.png"  # no image of an earlier run stands in for one this run did not write
    shots+=(--view "$2" --out "$out/$1.png")
    shift 2
  done
  cd "$source_dir" || exit 1
  "$snapshot" --project "$project" --estimate "${shots[@]}" \
    || { echo "FAIL: greybench-snapshot failed" >&2; exit 1; }
  echo "PASS: rendered $(( ${#shots[@]} / 4 )) views"
  exit 0
fi

rendered=0
if [[ ${1:-} == --rendered ]]; then
  rendered=1
  shift
  png_diff="$1"; source_dir="$2"; out="$3"; name="$4"
else
  snapshot="$1"; png_diff="$2"; source_dir="$3"; out="$4"; name="$5"; project="$6"; view="$7"
  shift 7
fi
mkdir -p "$out"
golden="$source_dir/screenshots/$name.png"
actual="$out/$name.png"

[[ -f $golden ]] || { echo "FAIL: no golden $golden (run scripts/update-goldens.sh)" >&2; exit 1; }
if [[ $rendered == 1 ]]; then
  [[ -f $actual ]] || { echo "FAIL: $actual was not rendered (ui.golden.render-estimated)" >&2; exit 1; }
else
  # The goldens are 1280 x 800, greybench-snapshot's default size. The project is opened by its
  # path relative to the source tree, as scripts/update-goldens.sh does, so that the paths the
  # views print do not depend on where the tree is checked out.
  cd "$source_dir" || exit 1
  "$snapshot" --project "$project" --view "$view" "$@" --out "$actual" \
    || { echo "FAIL: greybench-snapshot failed" >&2; exit 1; }
fi
if ! "$png_diff" "$actual" "$golden" --diff "$out/$name.diff.png"; then
  echo "FAIL: $actual differs from $golden; if the change is intended, run" \
       "scripts/update-goldens.sh and look at the new images before committing them" >&2
  exit 1
fi
echo "PASS: $name"
