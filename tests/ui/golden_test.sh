#!/usr/bin/env bash
# Renders one view with greybench-snapshot and compares it with its golden image.
#
#   golden_test.sh SNAPSHOT_EXE PNG_DIFF_EXE SOURCE_DIR OUT_DIR NAME PROJECT VIEW [--estimate]
#
# The golden is SOURCE_DIR/screenshots/NAME.png (screenshots/goldens.txt lists them;
# scripts/update-goldens.sh rewrites them). On a mismatch the rendering and an image of the
# differences are left in OUT_DIR. Exit 0 match, 1 mismatch or failure.
set -uo pipefail

snapshot="$1"; png_diff="$2"; source_dir="$3"; out="$4"; name="$5"; project="$6"; view="$7"
shift 7
mkdir -p "$out"
golden="$source_dir/screenshots/$name.png"
actual="$out/$name.png"

[[ -f $golden ]] || { echo "FAIL: no golden $golden (run scripts/update-goldens.sh)" >&2; exit 1; }
# The goldens are 1280 x 800, greybench-snapshot's default size. The project is opened by its
# path relative to the source tree, as scripts/update-goldens.sh does, so that the paths the
# views print do not depend on where the tree is checked out.
cd "$source_dir" || exit 1
"$snapshot" --project "$project" --view "$view" "$@" --out "$actual" \
  || { echo "FAIL: greybench-snapshot failed" >&2; exit 1; }
if ! "$png_diff" "$actual" "$golden" --diff "$out/$name.diff.png"; then
  echo "FAIL: $actual differs from $golden; if the change is intended, run" \
       "scripts/update-goldens.sh and look at the new images before committing them" >&2
  exit 1
fi
echo "PASS: $name"
