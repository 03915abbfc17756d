#!/usr/bin/env bash
# The Ornstein2D structure from every generic start (docs/benchmarks.md, "Runaways put back to
# their starts", issue 33): the 128 starts with logtheta, logalpha and the four log-SDs at ±1 and
# mu at 0 or 1, for ZOH and FOH, each fitted with the default options (or with EXTRA options);
# prints how many starts ended at each log L.
#
#   bench/generic_starts.sh [DATA.csv] [EXTRA estimate options...]
#       DATA: default tests/data/ornstein2d/data.csv (greybench's simulation); ctsmTMB's own
#       example data (not in the tree): the 50 rows of its Ornstein2D example, exported to CSV
#   CLI=path/to/greybench-cli bench/generic_starts.sh ...   another build (default build/)
set -euo pipefail
cd "$(dirname "$0")/.."
data=${1:-tests/data/ornstein2d/data.csv}
shift || true
cli=${CLI:-build/app/greybench-cli}
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
python3 - tests/data/ornstein2d/model.json "$tmp" <<'PY'
import itertools, json, sys
base = json.load(open(sys.argv[1]))
names = ["logtheta", "mu", "logalpha", "logsigma_x1", "logsigma_x2", "logsigma_y1", "logsigma_y2"]
for hold in ["zoh", "foh"]:
    for i, values in enumerate(itertools.product([1, -1], [0, 1], *[[1, -1]] * 5)):
        m = json.loads(json.dumps(base))
        m["input_hold"] = hold
        for name, v in zip(names, values):
            m["parameters"][name]["value"] = v
        json.dump(m, open(f"{sys.argv[2]}/{hold}_{i:03d}.json", "w"))
PY
for hold in zoh foh; do
  echo "== $hold: starts at each log L (of 128)"
  for model in "$tmp"/${hold}_*.json; do
    "$cli" estimate "$model" "$data" --threads 1 "$@" 2>/dev/null |
      awk '/^Log-likelihood:/ { print $2 }' || true
  done | sort | uniq -c | sort -rn
done
