#!/usr/bin/env bash
# Two builds of bench/loglik_bench side by side for docs/benchmarks.md (issue 36): the rounds
# alternate between the binaries, so a change of load on the shared machine hits both alike.
#
#   bench/loglik_ab.sh BASE_BIN NEW_BIN [ROUNDS]      (default 7)
#   FILTER='BM_BundledEkf/[0-3]/1' bench/loglik_ab.sh ...   other benchmarks (issue 37)
#
# BASE_BIN: a loglik_bench built from another commit (git worktree add, then its own build).
# Prints, per benchmark, the median CPU ms of each binary, their ratio and every round.
set -euo pipefail
base=${1:?BASE_BIN}
new=${2:?NEW_BIN}
rounds=${3:-7}
filter=${FILTER:-'BM_FuelFilm2State$|BM_Chain4State$|BM_FuelFilm2StateScore/1$|BM_Chain4StateScore/1$|BM_Chain10StateScore/1$|BM_EkfTanks2State/1$'}
out=$(mktemp)
trap 'rm -f "$out"' EXIT
for _ in $(seq 1 "$rounds"); do
  for tagged in "base:$base" "new:$new"; do
    tag=${tagged%%:*}
    "${tagged#*:}" --benchmark_filter="$filter" --benchmark_min_time=0.3 \
      --benchmark_format=json 2>/dev/null |
      python3 -c "
import json, sys
for b in json.load(sys.stdin)['benchmarks']:
    print('$tag', b['name'], b['cpu_time'])" >>"$out"
  done
done
python3 - "$out" <<'PY'
import statistics, sys
runs = {}
for line in open(sys.argv[1]):
    tag, name, ms = line.split()
    runs.setdefault(name, {}).setdefault(tag, []).append(float(ms))
for name, r in runs.items():
    b, n = statistics.median(r['base']), statistics.median(r['new'])
    rounds = lambda v: ' '.join(f'{x:.2f}' for x in sorted(v))
    print(f'{name:26s} base {b:8.3f}  new {n:8.3f}  new/base {n / b:5.2f}'
          f'   base: {rounds(r["base"])} | new: {rounds(r["new"])}')
PY
