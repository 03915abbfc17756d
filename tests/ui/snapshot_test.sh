#!/usr/bin/env bash
# Drives greybench-snapshot (and, under Xvfb, the greybench window) on the tiny project in
# tests/data/ui and checks what comes out.
#
#   snapshot_test.sh CASE SNAPSHOT_EXE PNG_CHECK_EXE DATA_DIR OUT_DIR [GREYBENCH_EXE SOURCE_DIR]
#
# CASE: data | equations | placeholder | deterministic | bad-project | bad-view | estimate |
#       estimate-deterministic | estimate-case-study | dialog | window.
# Exit 0 pass, 1 fail, 77 skipped (window test without xvfb-run).
set -uo pipefail

case_name="$1"; snapshot="$2"; png_check="$3"; data="$4"; out="$5"
project="$data/project.json"
mkdir -p "$out"

fail() { echo "FAIL: $*" >&2; exit 1; }

# Runs a command expecting exit status $1 and a stderr line matching $2.
expect_error() {
  local status="$1" pattern="$2"; shift 2
  local err
  err="$("$@" 2>&1 >/dev/null)"
  local rc=$?
  echo "$err"
  [[ $rc -eq $status ]] || fail "exit status $rc, expected $status"
  grep -q -- "$pattern" <<<"$err" || fail "stderr does not mention '$pattern'"
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
  placeholder)
    for view in diagram estimate predictions residuals parameters operating-points; do
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
    ;;
  bad-view)
    expect_error 2 "unknown view 'plots'" \
      "$snapshot" --project "$project" --view plots --out "$out/bad.png"
    ;;
  estimate|estimate-case-study)
    # The estimate and parameters views after --estimate. Exact colours prove the fit is drawn:
    # the red estimate point of the delay profile (estimate view), the dark red diagonal cells
    # of the correlation heat map (parameters view).
    if [[ $case_name == estimate-case-study ]]; then
      source_dir="$7"; project="$source_dir/assets/projects/case_study.json"
    fi
    "$snapshot" --project "$project" --view estimate --estimate \
      --out "$out/$case_name-estimate.png" || fail "snapshot of estimate failed"
    "$png_check" "$out/$case_name-estimate.png" 1280 800 --colour d62728:40 \
      || fail "$case_name-estimate.png"
    "$snapshot" --project "$project" --view parameters --estimate \
      --out "$out/$case_name-parameters.png" || fail "snapshot of parameters failed"
    "$png_check" "$out/$case_name-parameters.png" 1280 800 --colour b2182b:2000 \
      || fail "$case_name-parameters.png"
    # Without --estimate the same view has no fit to show.
    "$snapshot" --project "$project" --view parameters --out "$out/$case_name-no-fit.png" \
      || fail "snapshot without --estimate failed"
    if "$png_check" "$out/$case_name-no-fit.png" 1280 800 --colour b2182b:2000 >/dev/null 2>&1; then
      fail "the parameters view shows a heat map without a fit"
    fi
    ;;
  estimate-deterministic)
    for i in 1 2; do
      "$snapshot" --project "$project" --view estimate --estimate --out "$out/est-det$i.png" \
        || fail "run $i"
    done
    cmp "$out/est-det1.png" "$out/est-det2.png" || fail "two renderings after --estimate differ"
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
    ;;
  *)
    fail "unknown case '$case_name'"
    ;;
esac
echo "PASS: $case_name"
