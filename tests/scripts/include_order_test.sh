#!/usr/bin/env bash
# scripts/include-order.py: the source tree follows the order; a copy of core/ and ui/ with one
# back edge planted (core/util including core/project) fails with that edge's file and line.
#   include_order_test.sh PYTHON SOURCE_DIR
set -uo pipefail
python=$1
source_dir=$2
script=$source_dir/scripts/include-order.py
fail() { echo "FAIL: $*" >&2; exit 1; }

out=$("$python" "$script" --root "$source_dir") || fail "the tree breaks the order: $out"
grep -q '^include-order: .* follow core/ util < ' <<<"$out" || fail "no summary: $out"

tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
cp -r "$source_dir/core" "$source_dir/ui" "$tmp/"
printf '#include "core/project/project.h"\n' >>"$tmp/core/util/result.h"
line=$(wc -l <"$tmp/core/util/result.h")
out=$("$python" "$script" --root "$tmp")
status=$?
[[ $status == 1 ]] || fail "a back edge exits $status, not 1: $out"
grep -qxF "core/util/result.h:$line: core/util includes core/project, which is above it in the order" \
  <<<"$out" || fail "the back edge is not named: $out"

# Beside it (two folders on one line) and an unknown folder are refused too.
cp "$source_dir/core/util/result.h" "$tmp/core/util/result.h"
printf '#include "core/sim/sde.h"\n' >>"$tmp/core/online/cusum.h"
mkdir "$tmp/core/newfolder" && printf '#include "core/util/result.h"\n' >"$tmp/core/newfolder/a.h"
out=$("$python" "$script" --root "$tmp") && fail "beside and unknown pass: $out"
grep -q "core/online/cusum.h:.*core/online includes core/sim, which is beside it" <<<"$out" \
  || fail "the edge between folders of one line is not named: $out"
grep -q "core/newfolder/a.h:1: core/newfolder is not in the order" <<<"$out" \
  || fail "the unknown folder is not named: $out"
echo "include-order: the tree passes; planted back, beside and unknown edges fail"
