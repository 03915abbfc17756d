#!/usr/bin/env bash
# greybench-cli report: the estimation report of a result file as Markdown and as HTML. Both hold
# every estimate and standard error to the precision the text report prints (read from the result
# file itself), the HTML is well-formed XML with the two figures inline as SVG whose polyline
# holds the predictions, the residual analysis appears with the model and the data, and bad input
# (a missing or foreign result file, an unknown format, --out onto an input) exits 2 naming the
# file or the option, writing nothing.
# Usage: report.sh GREYBENCH_CLI TEST_DATA_DIR
set -u
cli=$(realpath "$1")
data=$2
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
source "$(dirname "${BASH_SOURCE[0]}")/expect.bash"

pass() { passes=$((passes + 1)); }
fail() { echo "FAIL: $*"; failures=$((failures + 1)); }

cp "$data/cli/fuel.json" "$data/cli/fuel.csv" "$tmp/"
(cd "$tmp" && timeout 60 "$cli" estimate fuel.json fuel.csv --out result.json >/dev/null 2>&1) ||
  fail "estimate for the report's result file"

# The result names its model and data (relative to it): the report finds them.
if (cd "$tmp" && timeout 60 "$cli" report result.json --out report.md 2>"$tmp/err" &&
    timeout 60 "$cli" report result.json --format html --out report.html 2>>"$tmp/err"); then
  pass
else
  fail "report: $(cat "$tmp/err")"
fi

# Every estimate and standard error as the text report prints it (%.6g), in both files.
python3 - "$tmp/result.json" "$tmp/report.md" "$tmp/report.html" <<'PY' && pass || fail "estimates in the report"
import json, sys
result = json.load(open(sys.argv[1]))
for path in sys.argv[2:]:
    text = open(path, encoding="utf-8").read()
    for name, p in result["parameters"].items():
        for key in ("estimate", "std_error"):
            v = p.get(key)
            if v is None or (key == "std_error" and p["fixed"]):
                continue
            if "%.6g" % v not in text:
                sys.exit(f"{path}: {name} {key} {'%.6g' % v} missing")
    if "%.6f" % result["loglik"] not in text:
        sys.exit(f"{path}: log L {'%.6f' % result['loglik']} missing")
    for word in ("Ljung-Box", "Jarque-Bera", "Correlation of the estimates"):
        if word not in text:
            sys.exit(f"{path}: no {word}")
PY

# The HTML: well-formed XML (so its inline SVG is too), two figures, nothing non-finite.
if command -v xmllint >/dev/null 2>&1; then
  xmllint --noout "$tmp/report.html" && pass || fail "report.html is not well-formed"
fi
[ "$(grep -c '<svg ' "$tmp/report.html")" -eq 2 ] && pass || fail "report.html: not two figures"
grep -Eqi '(^|[^a-z])(nan|inf)([^a-z]|$)' "$tmp/report.md" && fail "report.md prints a non-finite" || pass

# The predictions' polyline, mapped back by the attributes of its plot-data group (figure.h),
# gives the one-step predictions `predict` writes.
(cd "$tmp" && timeout 60 "$cli" predict fuel.json fuel.csv --result result.json --out pred.csv \
  >/dev/null 2>&1) || fail "predict"
python3 - "$tmp/report.html" "$tmp/pred.csv" <<'PY' && pass || fail "the SVG's predictions"
import csv, re, sys
html = open(sys.argv[1], encoding="utf-8").read()
svg = html[html.index("<svg "):html.index("</svg>")]
area = [float(v) for v in re.search(r'gb:plot-area="([^"]*)"', svg).group(1).split()]
xr = [float(v) for v in re.search(r'gb:x-range="([^"]*)"', svg).group(1).split()]
yr = [float(v) for v in re.search(r'gb:y-range="([^"]*)"', svg).group(1).split()]
points = []
for run in re.findall(r'<polyline points="([^"]*)"', svg):
    for p in run.split():
        px, py = (float(v) for v in p.split(","))
        points.append((xr[0] + (px - area[0]) / (area[2] - area[0]) * (xr[1] - xr[0]),
                       yr[0] + (area[3] - py) / (area[3] - area[1]) * (yr[1] - yr[0])))
rows = [r for r in csv.reader(l for l in open(sys.argv[2]) if not l.startswith("#"))]
head, rows = rows[0], rows[1:]
t, pred = head.index("t"), [i for i, h in enumerate(head) if h.endswith("_pred")][0]
expected = [(float(r[t]), float(r[pred])) for r in rows if r[pred] not in ("", "NA", "nan", "NaN")]
if len(points) != len(expected):
    sys.exit(f"{len(points)} points, {len(expected)} predictions")
for (x, y), (te, ye) in zip(points, expected):
    if abs(x - te) > 1e-9 * max(1, abs(te)) or abs(y - ye) > 1e-9 * max(1, abs(ye)):
        sys.exit(f"({x}, {y}) read back, ({te}, {ye}) predicted")
PY

# Without the model and data at hand: the tables, and a note that says how to get the rest.
mkdir -p "$tmp/alone" && cp "$tmp/result.json" "$tmp/alone/"
expect 0 "no residual analysis.*--model and --data" -- report "$tmp/alone/result.json" --out "$tmp/alone/r.md"
grep -q "Give the model and the data with --model and --data" "$tmp/alone/r.md" && pass || fail "the note"
expect 0 "" -- report "$tmp/alone/result.json" --model "$tmp/fuel.json" --data "$tmp/fuel.csv" --out "$tmp/alone/r2.md"
grep -q "Ljung-Box" "$tmp/alone/r2.md" && pass || fail "--model --data: no residual analysis"

# Bad input: exit 2, the file or the option named, nothing written.
kept=("$tmp/result.json" "$tmp/fuel.json" "$tmp/fuel.csv")
expect_kept 2 "no_such.json" -- report "$tmp/no_such.json" --out "$tmp/x.md"
expect_kept 2 "fuel.json: greybench_result: not a greybench result file" -- report "$tmp/fuel.json" --out "$tmp/x.md"
expect_kept 2 "--format 'pdf': expected md or html" -- report "$tmp/result.json" --format pdf --out "$tmp/x.pdf"
expect_kept 2 "--out .*x.txt: give --format md or --format html" -- report "$tmp/result.json" --out "$tmp/x.txt"
expect_kept 2 "--out .*result.json" -- report "$tmp/result.json" --format md --out "$tmp/result.json"
expect_kept 2 "--out .*fuel.csv" -- report "$tmp/result.json" --format md --out "$tmp/fuel.csv"
expect_kept 2 "--out .*fuel.json" -- report "$tmp/result.json" --format html --out "$tmp/fuel.json"
expect_kept 2 "--model.*no_model.json|no_model.json" -- report "$tmp/result.json" --model "$tmp/no_model.json" --out "$tmp/x.md"
[ ! -e "$tmp/x.md" ] && [ ! -e "$tmp/x.pdf" ] && [ ! -e "$tmp/x.txt" ] && pass || fail "a refused report left a file"

summary report
