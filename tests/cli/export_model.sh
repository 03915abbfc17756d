#!/usr/bin/env bash
# greybench-cli export-model: the model a project's block diagram compiles to. The bundled diagrams
# export to models with the log-likelihood of the hand-written ones; a project without a diagram,
# or with a diagram that does not compile, is bad input (exit 2) with a message naming the block.
# Usage: export_model.sh GREYBENCH_CLI TEST_DATA_DIR
set -u
cli=$1
assets=$(cd "$(dirname "$0")/../../assets" && pwd)
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
source "$(dirname "${BASH_SOURCE[0]}")/expect.bash"

# same_loglik MODEL_A MODEL_B DATA: both models give the same loglik output on DATA.
same_loglik() {
  local a b
  a=$("$cli" loglik "$1" "$3" 2>&1)
  b=$("$cli" loglik "$2" "$3" 2>&1)
  if [ -z "$a" ] || [ "$a" != "$b" ]; then
    echo "FAIL: loglik of $1 ($a) differs from $2 ($b) on $3"
    failures=$((failures + 1))
  else
    passes=$((passes + 1))
  fi
}

# project NAME DIAGRAM-JSON-OR-PATH: writes $tmp/NAME.json naming the fuel-film model and data.
project() {
  python3 - "$tmp/$1.json" "$2" "$assets" <<'PY'
import json, sys
out, diagram, assets = sys.argv[1], sys.argv[2], sys.argv[3]
try:
    diagram = json.loads(diagram)
except ValueError:
    pass
p = {"greybench_project": 1, "name": "test", "model": assets + "/models/fuel_film.json",
     "datasets": [assets + "/data/fuel_f1.csv"], "diagram": diagram}
json.dump(p, open(out, "w"), indent=1)
PY
}

# edit NAME PYTHON-ON-d: writes $tmp/NAME.json, a project with the fuel-film diagram inline, edited.
edit() {
  python3 - "$assets/diagrams/fuel_film.json" "$tmp/$1.json" "$2" "$assets" <<'PY'
import json, sys
d = json.load(open(sys.argv[1]))
exec(sys.argv[3])
assets = sys.argv[4]
p = {"greybench_project": 1, "name": "test", "model": assets + "/models/fuel_film.json",
     "datasets": [assets + "/data/fuel_f1.csv"], "diagram": d}
json.dump(p, open(sys.argv[2], "w"), indent=1)
PY
}

# --- the bundled diagrams export to the models of the paper ----------------------------------
expect 0 "^$" -- export-model "$assets/projects/fuel_film_diagram.json" --out "$tmp/fuel.json"
same_loglik "$tmp/fuel.json" "$assets/models/fuel_film.json" "$assets/data/fuel_f1.csv"

project crank "$assets/diagrams/crankshaft.json"
expect 0 "^$" -- export-model "$tmp/crank.json" --out "$tmp/crank_model.json"
same_loglik "$tmp/crank_model.json" "$assets/models/crankshaft.json" "$assets/data/crankshaft.csv"

edit inline 'pass'
expect 0 "^$" -- export-model "$tmp/inline.json" --out "$tmp/inline_model.json"
same_loglik "$tmp/inline_model.json" "$assets/models/fuel_film.json" "$assets/data/fuel_f1.csv"

# --- bad input --------------------------------------------------------------------------------
expect 2 "fuel_f1.json: the project has no diagram" -- export-model "$assets/projects/fuel_f1.json" --out "$tmp/x.json"

project missing "nowhere.json"
expect 2 "nowhere.json.*(cannot|no such)" -- export-model "$tmp/missing.json" --out "$tmp/x.json"

edit unconnected 'd["links"] = [l for l in d["links"] if l["id"] != 16]'
expect 2 "unconnected.json: block 6, in-port 0: in-port 'u' is not connected" -- export-model "$tmp/unconnected.json" --out "$tmp/x.json"

edit unknown 'd["blocks"][2]["tau"] = "tau_fvv"'
expect 2 "unknown.json: block 3.tau, column 1: unknown name 'tau_fvv' \(did you mean 'tau_fv'\?\)" -- export-model "$tmp/unknown.json" --out "$tmp/x.json"

edit novariance 'del d["blocks"][7]["variance"]'
expect 2 "block 8.variance: the output has no measurement variance" -- export-model "$tmp/novariance.json" --out "$tmp/x.json"

edit delay 'd["links"] = [l for l in d["links"] if l["id"] not in (17, 18)] + [{"id": 30, "from": [5, 0], "to": [7, 0]}, {"id": 31, "from": [7, 0], "to": [6, 0]}, {"id": 32, "from": [6, 0], "to": [8, 0]}]'
expect 2 "block 7: a delay may only sit directly in front of an output" -- export-model "$tmp/delay.json" --out "$tmp/x.json"

edit kind 'd["blocks"][1]["kind"] = "spilt"'
expect 2 "kind.json: diagram.blocks\[1\].kind: unknown kind 'spilt'" -- export-model "$tmp/kind.json" --out "$tmp/x.json"

edit link 'd["links"][0]["to"] = [2, 3]'
expect 2 "link.json: diagram.links\[0\].to\[1\]: .*has no in-port 3" -- export-model "$tmp/link.json" --out "$tmp/x.json"

# --- a hostile diagram: 100 000 blocks, none connected (issue 32: checking took time quadratic in
# them, 20 000 blocks 50 s). Each block's problems are found in one pass; the first 20 are printed
# with their count, promptly, and the project is left as it was.
python3 - "$tmp/large.json" "$assets" <<'PY'
import json, sys
kinds = ["gain", "sum", "lag", "output"]
blocks = []
for i in range(1, 100001):
    b = {"id": i, "kind": kinds[i % 4]}
    if b["kind"] == "lag": b["name"] = "x%d" % i
    if b["kind"] == "output": b["name"], b["variance"] = "y%d" % i, "1"
    blocks.append(b)
d = {"greybench_diagram": 1, "blocks": blocks, "links": [],
     "layout": {str(b["id"]): [b["id"], 0] for b in blocks}}
p = {"greybench_project": 1, "name": "large", "model": sys.argv[2] + "/models/fuel_film.json",
     "datasets": [], "diagram": d}
json.dump(p, open(sys.argv[1], "w"))
PY
large_sum=$(sha256sum "$tmp/large.json")
# "Promptly" is 10 s of the release build (quadratic checking took 50 s for 20 000 blocks); the
# sanitizers' build reads and frees the 100 000 blocks several times slower.
[[ ${GREYBENCH_SANITIZED:-0} == 1 ]] && EXPECT_TIMEOUT=60
expect 2 "large.json: the diagram has 125002 problems; the first 20 are above" -- export-model "$tmp/large.json" --out "$tmp/x.json"
expect 2 "large.json: block 1, in-port 0: in-port '\+u1' is not connected" -- export-model "$tmp/large.json" --out "$tmp/x.json"
check "export-model leaves the project of 100 000 blocks as it was" \
  test "$(sha256sum "$tmp/large.json")" = "$large_sum"
lines=$("$cli" export-model "$tmp/large.json" --out "$tmp/x.json" 2>&1 | wc -l)
check "export-model prints 21 lines for 125 002 problems, not one per problem ($lines)" test "$lines" -eq 21

[ -e "$tmp/x.json" ] && { echo "FAIL: a refused export wrote its output"; failures=$((failures + 1)); }

summary
