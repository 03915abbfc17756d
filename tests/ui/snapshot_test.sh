#!/usr/bin/env bash
# Drives greybench-snapshot (and, under Xvfb, the greybench window) on the tiny project in
# tests/data/ui and checks what comes out.
#
#   snapshot_test.sh CASE SNAPSHOT_EXE PNG_CHECK_EXE DATA_DIR OUT_DIR [GREYBENCH_EXE SOURCE_DIR]
#
# CASE: data | equations | small | deterministic | bad-project | bad-view | estimate |
#       estimate-deterministic | estimate-case-study | operating-points | diagram | dialog |
#       predictions | residuals | live | plot | window.
# Exit 0 pass, 1 fail, 77 skipped (window test without xvfb-run).
set -uo pipefail

case_name="$1"; snapshot="$2"; png_check="$3"; data="$4"; out="$5"
project="$data/project.json"
mkdir -p "$out"

fail() { echo "FAIL: $*" >&2; exit 1; }

# Runs of a case that checks two renderings give the same bytes: one under the sanitizers
# (GREYBENCH_SANITIZED=1, set by tests/ui/CMakeLists.txt), where a second run adds no code; the
# release suite compares the two.
runs=2
[[ ${GREYBENCH_SANITIZED:-0} == 1 ]] && runs=1

# Runs a command expecting exit status $1 and a stderr line matching $2.
expect_error() {
  local status="$1" pattern="$2"; shift 2
  local err
  err="$("$@" 2>&1 >/dev/null)"
  local rc=$?
  echo "$err"
  [[ $rc -eq $status ]] || fail "exit status $rc, expected $status"
  grep -Eq -- "$pattern" <<<"$err" || fail "stderr does not mention '$pattern'"
}

case "$case_name" in
  data)
    "$snapshot" --project "$project" --view data --out "$out/data.png" || fail "snapshot failed"
    "$png_check" "$out/data.png" 1280 800 || fail "data.png"
    ;;
  equations)
    "$snapshot" --project "$project" --view equations --out "$out/equations.png" \
      --width 1024 --height 700 || fail "snapshot failed"
    "$png_check" "$out/equations.png" 1024 700 || fail "equations.png"
    ;;
  small)
    # Every view in a small window (800 x 500) still draws.
    for view in data diagram equations estimate predictions residuals parameters \
                operating-points live; do
      "$snapshot" --project "$project" --view "$view" --out "$out/$view.png" \
        --width 800 --height 500 || fail "snapshot of $view failed"
      "$png_check" "$out/$view.png" 800 500 || fail "$view.png"
    done
    ;;
  deterministic)
    "$snapshot" --project "$project" --view data --out "$out/det1.png" || fail "first run"
    "$snapshot" --project "$project" --view data --out "$out/det2.png" || fail "second run"
    cmp "$out/det1.png" "$out/det2.png" || fail "two renderings of the same input differ"
    ;;
  bad-project)
    expect_error 2 "no_such_project.json" \
      "$snapshot" --project "$data/no_such_project.json" --view data --out "$out/bad.png"
    expect_error 2 "broken_data.csv" \
      "$snapshot" --project "$data/broken_project.json" --view data --out "$out/bad.png"
    # An image never lands on a file the project is made of, nor two images on one file; a copy
    # of the project keeps every byte.
    copy="$out/guarded"
    rm -rf "$copy" && mkdir -p "$copy"
    cp "$data/project.json" "$data/fuel_film.json" "$data/f1.csv" "$copy/"
    (cd "$copy" && sha256sum project.json fuel_film.json f1.csv) >"$out/guarded.sha256"
    for target in project.json fuel_film.json f1.csv; do
      expect_error 2 "--out $copy/$target is .*the project" \
        "$snapshot" --project "$copy/project.json" --view data --out "$copy/$target"
    done
    expect_error 2 "is also the path of --out" \
      "$snapshot" --project "$copy/project.json" --view data --out "$copy/a.png" \
      --view residuals --out "$copy/./a.png"
    (cd "$copy" && sha256sum --quiet -c "$out/guarded.sha256") || fail "an input changed"
    ;;
  bad-view)
    expect_error 2 "unknown view 'plots'" \
      "$snapshot" --project "$project" --view plots --out "$out/bad.png"
    expect_error 2 "--time '30:20': expected T0:T1 with T0 < T1" \
      "$snapshot" --project "$project" --view predictions --time 30:20 --out "$out/bad.png"
    ;;
  estimate|estimate-case-study)
    # The estimate and parameters views after --estimate. Exact colours prove the fit is drawn:
    # the red estimate point of the delay profile (estimate view), the dark red diagonal cells
    # of the correlation heat map (parameters view).
    if [[ $case_name == estimate-case-study ]]; then
      # Not under the sanitizers: the case study's fit took 94 s there, and the same views after
      # the same --estimate path are drawn there by the `estimate` case on the test project.
      if [[ ${GREYBENCH_SANITIZED:-0} == 1 ]]; then
        echo "skipped under the sanitizers: the estimate case runs this path there"
        exit 77
      fi
      source_dir="$7"; project="$source_dir/assets/projects/case_study.json"
    fi
    # Both views from one run (one estimation), as several --view/--out pairs draw them.
    "$snapshot" --project "$project" --estimate --view estimate \
      --out "$out/$case_name-estimate.png" --view parameters \
      --out "$out/$case_name-parameters.png" || fail "snapshot of estimate and parameters failed"
    "$png_check" "$out/$case_name-estimate.png" 1280 800 --colour d62728:40 \
      || fail "$case_name-estimate.png"
    "$png_check" "$out/$case_name-parameters.png" 1280 800 --colour b2182b:2000 \
      || fail "$case_name-parameters.png"
    # Without --estimate the same view has no fit to show.
    "$snapshot" --project "$project" --view parameters --out "$out/$case_name-no-fit.png" \
      || fail "snapshot without --estimate failed"
    if "$png_check" "$out/$case_name-no-fit.png" 1280 800 --colour b2182b:2000 >/dev/null 2>&1; then
      fail "the parameters view shows a heat map without a fit"
    fi
    ;;
  live)
    # The live view run to 10 s without a clock, from the session's estimate (a poor one: the
    # test model fixes K_b at 1, so the monitor alarms at once), with a fault at 5 s: the red
    # alarm banner (c62828) and the fault's orange line and tag (e67800) prove the run and its
    # marks are drawn; two runs give the same bytes.
    # Under the sanitizers one run: the second adds no code, only the comparison of the bytes.
    for ((i = 1; i <= runs; ++i)); do
      "$snapshot" --project "$project" --estimate --view live --live-until 10 \
        --live-fault '5:tau_ff*1.5' --out "$out/live$i.png" || fail "run $i"
    done
    "$png_check" "$out/live1.png" 1280 800 --colour c62828:10000 --colour e67800:10 \
      || fail "live1.png"
    if ((runs == 2)); then
      cmp "$out/live1.png" "$out/live2.png" || fail "two renderings of the same live run differ"
    fi
    expect_error 2 "--live-fault needs --live-until" \
      "$snapshot" --project "$project" --view live --live-fault '5:X*2' --out "$out/bad.png"
    expect_error 2 "--live-fault '5:tauff\*2': unknown parameter 'tauff'" \
      "$snapshot" --project "$project" --view live --live-until 10 --live-fault '5:tauff*2' \
      --out "$out/bad.png"
    expect_error 2 "--live-fault '5:X\*9': X would become" \
      "$snapshot" --project "$project" --view live --live-until 10 --live-fault '5:X*9' \
      --out "$out/bad.png"
    expect_error 2 "run an estimate first, or open a result file" \
      "$snapshot" --project "$project" --view live --live-until 10 --out "$out/bad.png"
    ;;
  estimate-deterministic)
    if ((runs == 1)); then
      echo "skipped under the sanitizers: the estimate case runs this path there"
      exit 77
    fi
    for i in 1 2; do
      "$snapshot" --project "$project" --view estimate --estimate --out "$out/est-det$i.png" \
        || fail "run $i"
    done
    cmp "$out/est-det1.png" "$out/est-det2.png" || fail "two renderings after --estimate differ"
    ;;
  operating-points)
    # The sweep of tests/data/ui/sweep (three short tagged datasets). Exact colours prove the
    # sweep is drawn: the red fitted c / n curve and least-squares line, the blue error bars.
    sweep="$data/sweep/project.json"
    # Under the sanitizers the sweep's fits run the quick way (--quick-sweep: each point's delay
    # profile evaluated at its estimate, no extra starts; the same table in a fraction of the
    # fits), as the workbench tests' driver runs them there.
    quick=()
    [[ ${GREYBENCH_SANITIZED:-0} == 1 ]] && quick=(--quick-sweep)
    "$snapshot" --project "$sweep" --view operating-points --out "$out/op-no-sweep.png" \
      || fail "snapshot without --estimate failed"
    "$png_check" "$out/op-no-sweep.png" 1280 800 || fail "op-no-sweep.png"
    if "$png_check" "$out/op-no-sweep.png" 1280 800 --colour d62728:150 >/dev/null 2>&1; then
      fail "the view shows fitted curves without a sweep"
    fi
    "$snapshot" --project "$sweep" --view operating-points --estimate "${quick[@]}" \
      --out "$out/op-sweep.png" || fail "snapshot with --estimate failed"
    "$png_check" "$out/op-sweep.png" 1280 800 --colour d62728:150 --colour 1f77b4:100 \
      || fail "op-sweep.png"
    if ((runs == 2)); then
      "$snapshot" --project "$sweep" --view operating-points --estimate "${quick[@]}" \
        --out "$out/op-sweep2.png" || fail "second snapshot with --estimate failed"
      cmp "$out/op-sweep.png" "$out/op-sweep2.png" || fail "two renderings after the sweep differ"
    fi
    # A wrong key: --estimate refuses with the file and the JSON path.
    expect_error 2 "bad_project.json: operating_points.trend.tag" \
      "$snapshot" --project "$data/sweep/bad_project.json" --view operating-points --estimate \
      --out "$out/op-bad.png"
    ;;
  diagram)
    # The block diagram of Fig. 1 (a project with a diagram) and FromModel's picture of the
    # equations-only test project. The orange of the process-noise ports and links (d67814)
    # proves the editor drew the noise blocks' wiring.
    source_dir="$7"
    "$snapshot" --project "$source_dir/assets/projects/fuel_film_diagram.json" --view diagram \
      --out "$out/diagram-fig1.png" || fail "snapshot of the fuel-film diagram failed"
    "$png_check" "$out/diagram-fig1.png" 1280 800 --colour d67814:20 || fail "diagram-fig1.png"
    "$snapshot" --project "$project" --view diagram --out "$out/diagram-from-model.png" \
      --width 1024 --height 700 || fail "snapshot of the equations-only diagram failed"
    "$png_check" "$out/diagram-from-model.png" 1024 700 --colour d67814:20 \
      || fail "diagram-from-model.png"
    ;;
  predictions|residuals)
    # The view at the model's values (no fit) and after --estimate, on the test project and the
    # case study. Exact colours prove what is drawn: predictions, the blue one-step prediction
    # line and the dark measurement markers; residuals, the verdict's stripe and word, red
    # ("not white") at the start values and green ("white and normal") at the estimates.
    # Under the sanitizers (GREYBENCH_SANITIZED=1, set by tests/ui/CMakeLists.txt) the test
    # project only, with and without a fit (the same code): the estimated case study's views are
    # the release suite's goldens, and its verdict (a statistical outcome) its check.
    source_dir="$7"
    projects=("$project")
    [[ ${GREYBENCH_SANITIZED:-0} == 1 ]] || projects+=("$source_dir/assets/projects/case_study.json")
    for p in "${projects[@]}"; do
      name="$case_name-$(basename "$p" .json)"
      if [[ $case_name == predictions ]]; then
        # The one-step prediction's exact blue: some 1000 pixels over the view's opening
        # window of 240 samples (a smooth line; the whole record's zigzag drew more).
        no_fit=(--colour 1f77b4:500 --colour 3c4048:200); fit=("${no_fit[@]}")
      else
        no_fit=(--colour c72929:200); fit=(--colour 228b22:200)
      fi
      "$snapshot" --project "$p" --view "$case_name" --out "$out/$name-no-fit.png" \
        || fail "snapshot of $name without a fit failed"
      "$png_check" "$out/$name-no-fit.png" 1280 800 "${no_fit[@]}" || fail "$name-no-fit.png"
      "$snapshot" --project "$p" --view "$case_name" --estimate --out "$out/$name-fit.png" \
        || fail "snapshot of $name after --estimate failed"
      "$png_check" "$out/$name-fit.png" 1280 800 "${fit[@]}" || fail "$name-fit.png"
    done
    ;;
  dialog)
    # The shell's dialogs drawn over the data view (--dialog), and an unknown one refused.
    for dialog in open-project save-project-as new-project keyboard-shortcuts unsaved-changes; do
      "$snapshot" --project "$project" --view data --dialog "$dialog" \
        --out "$out/dialog-$dialog.png" || fail "snapshot of $dialog failed"
      "$png_check" "$out/dialog-$dialog.png" 1280 800 || fail "dialog-$dialog.png"
    done
    expect_error 2 "dialog 'print'" \
      "$snapshot" --project "$project" --view data --dialog print --out "$out/bad.png"
    ;;
  plot)
    # One plot of a view without the window around it: the SVG is drawn from the plot's data
    # (its polyline, mapped back by the attributes of plot-data, gives the data file's values),
    # the PNG is the plot alone at the size asked for.
    rm -f "$out/mfi.svg" "$out/acf.png"
    "$snapshot" --project "$project" --view data --plot mfi --out "$out/mfi.svg" \
      --view residuals --plot "Autocorrelation of z" --out "$out/acf.png" \
      --width 640 --height 360 || fail "snapshot of one plot failed"
    if command -v xmllint >/dev/null 2>&1; then
      xmllint --noout "$out/mfi.svg" || fail "mfi.svg is not well-formed XML"
    else
      echo "xmllint not found: the SVG's XML is not checked"
    fi
    "$png_check" "$out/acf.png" 640 360 || fail "acf.png"
    # The polyline's points, mapped back, against the data file's mfi column (t, mfi, ...).
    awk -v svg="$out/mfi.svg" '
      BEGIN {
        while ((getline line < svg) > 0) {
          if (match(line, /gb:plot-area="[^"]*"/)) split(substr(line, RSTART + 14, RLENGTH - 15), a, " ")
          if (match(line, /gb:x-range="[^"]*"/)) split(substr(line, RSTART + 12, RLENGTH - 13), xr, " ")
          if (match(line, /gb:y-range="[^"]*"/)) split(substr(line, RSTART + 12, RLENGTH - 13), yr, " ")
          if (match(line, /<polyline points="[^"]*"/)) pts = substr(line, RSTART + 18, RLENGTH - 19)
        }
        n = split(pts, p, " ")
        for (i = 1; i <= n; ++i) {
          split(p[i], xy, ",")
          x[i] = xr[1] + (xy[1] - a[1]) / (a[3] - a[1]) * (xr[2] - xr[1])
          y[i] = yr[1] + (a[4] - xy[2]) / (a[4] - a[2]) * (yr[2] - yr[1])
        }
        FS = ","
      }
      /^#/ || /^t,/ { next }
      { ++row; if (row > n) { bad = 1; print "more rows than points"; exit }
        if ((x[row] - $1)^2 > 1e-18 || (y[row] - $2)^2 > 1e-18) {
          bad = 1; printf "row %d: %s,%s read back as %.12g,%.12g\n", row, $1, $2, x[row], y[row]; exit } }
      END { if (!bad && row != n) { print row " rows, " n " points"; bad = 1 } exit bad }
    ' "$data/f1.csv" || fail "the SVG's polyline does not give the data file's values"
    expect_error 2 "--plot 'nope': the data view has no plot of that name; its plots: 'mfi', 'ilambda'" \
      "$snapshot" --project "$project" --view data --plot nope --out "$out/bad.svg"
    expect_error 2 "--out $out/bad.svg: an SVG is drawn from one plot's data; give --plot NAME" \
      "$snapshot" --project "$project" --view data --out "$out/bad.svg"
    expect_error 2 "--plot mfi: give its --out after it" \
      "$snapshot" --project "$project" --view data --out "$out/bad.png" --plot mfi
    # Never onto a file of the project (a copy of it, which keeps every byte).
    copy="$out/plot-guarded"
    rm -rf "$copy" && mkdir -p "$copy"
    cp "$data/project.json" "$data/fuel_film.json" "$data/f1.csv" "$copy/"
    (cd "$copy" && sha256sum project.json fuel_film.json f1.csv) >"$out/plot-guarded.sha256"
    expect_error 2 "--out $copy/f1.csv is .*the project" \
      "$snapshot" --project "$copy/project.json" --view data --plot mfi --out "$copy/f1.csv"
    (cd "$copy" && sha256sum --quiet -c "$out/plot-guarded.sha256") || fail "an input changed"
    ;;
  window)
    greybench="$6"; source_dir="$7"
    if ! command -v xvfb-run >/dev/null 2>&1; then
      echo "xvfb-run not found: skipping the window test"
      exit 77
    fi
    rm -f "$out/window.png"
    "$source_dir/scripts/run-window-xvfb.sh" --exe "$greybench" --size 1280x800 \
      "$out/window.png" "$project" || fail "run-window-xvfb.sh failed"
    "$png_check" "$out/window.png" 1280 800 || fail "window.png"
    # File › Export › Image of the view: the view drawn offscreen at a projector's size.
    rm -f "$out/view-1024.png"
    "$source_dir/scripts/run-window-xvfb.sh" --exe "$greybench" --size 1280x800 \
      --view-image 1024x768 "$out/view-1024.png" "$project" || fail "the image of the view failed"
    "$png_check" "$out/view-1024.png" 1024 768 || fail "view-1024.png"
    ;;
  *)
    fail "unknown case '$case_name'"
    ;;
esac
echo "PASS: $case_name"
