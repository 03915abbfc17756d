#!/usr/bin/env bash
# Static checks on core/ (docs/quality.md): clang-tidy with the committed .clang-tidy, and
# cppcheck (warning, performance, portability) with the committed .cppcheck-suppressions.
# Fails (exit 1) on any finding of either; prints each tool's findings and run time.
#   scripts/static-checks.sh [BUILD_DIR]      BUILD_DIR holds compile_commands.json (default build)
#   JOBS=N scripts/static-checks.sh           N clang-tidy/cppcheck processes at once (default 1)
#   FILES="core/a.cpp core/b.cpp" scripts/...  clang-tidy on these files only (cppcheck: all)
# Needs: clang-tidy, cppcheck (Debian packages clang-tidy, cppcheck), a configured build.
set -uo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
build=$(cd "${1:-$root/build}" 2>/dev/null && pwd) || {
  echo "static-checks: no build directory ${1:-$root/build} (configure with cmake first)" >&2
  exit 2
}
jobs=${JOBS:-1}
if [ ! -f "$build/compile_commands.json" ]; then
  echo "static-checks: $build/compile_commands.json is missing (CMAKE_EXPORT_COMPILE_COMMANDS)" >&2
  exit 2
fi
for tool in clang-tidy cppcheck; do
  command -v "$tool" >/dev/null || { echo "static-checks: $tool is not installed" >&2; exit 2; }
done
cd "$root"
if [ -n "${FILES:-}" ]; then
  read -r -a sources <<<"$FILES"
else
  mapfile -t sources < <(git ls-files 'core/*.cpp')
  # Incremental, and sound: clang-tidy's findings on a translation unit depend only on its
  # sources and the configuration, so after a commit whose full check passed
  # (.ci/static-checks-base), only the units whose .cpp or any header they include (the build's
  # own dependency record, ninja -t deps) changed since are checked again; everything when the
  # configuration (.clang-tidy, the CMake files' flags) changed, or the base is not in the
  # history. STATIC_CHECKS_ALL=1 checks every file.
  base_file=$root/.ci/static-checks-base
  if [ -z "${STATIC_CHECKS_ALL:-}" ] && [ -f "$base_file" ]; then
    base=$(tr -d '[:space:]' <"$base_file")
    if git cat-file -e "$base^{commit}" 2>/dev/null; then
      changed=$(git diff --name-only "$base" HEAD)
      if ! grep -qxE '\.clang-tidy|CMakeLists\.txt|core/CMakeLists\.txt' <<<"$changed"; then
        selected=()
        for f in "${sources[@]}"; do
          deps=$(ninja -C "$build" -t deps "core/CMakeFiles/greybench_core.dir/${f#core/}.o" 2>/dev/null |
                 awk 'NR > 1 { print $1 }' | sed "s|^$root/||")
          if [ -z "$deps" ] || printf '%s\n' "$f" $deps | grep -qxF -f <(printf '%s\n' "$changed"); then
            selected+=("$f")
          fi
        done
        echo "static-checks: ${#selected[@]} of ${#sources[@]} files changed (with their headers) since $base, whose full check passed"
        sources=("${selected[@]}")
      fi
    fi
  fi
fi
logs=$(mktemp -d)
trap 'rm -rf "$logs"' EXIT
status=0

# clang-tidy: one process per file. The compile commands are GCC's; clang does not know some of
# its warning options (-Wno-restrict), which is not a finding.
start=$(date +%s)
printf '%s\n' "${sources[@]}" |
  xargs -P "$jobs" -I{} sh -c 'clang-tidy -p "$1" --quiet --extra-arg=-Wno-unknown-warning-option \
      "$2" >"$3/$(echo "$2" | tr / _).log" 2>&1 || echo "$2" >>"$3/failed"' _ "$build" {} "$logs"
tidy_s=$(( $(date +%s) - start ))
if [ -s "$logs/failed" ]; then
  for f in $(sort "$logs/failed"); do
    grep -v -e '^[0-9]* warnings\? generated' -e '^Suppressed [0-9]* warnings' \
      -e 'Use -header-filter=' -e '^$' "$logs/$(echo "$f" | tr / _).log"
  done
  echo "static-checks: clang-tidy: findings in $(wc -l <"$logs/failed") of ${#sources[@]} files (${tidy_s} s)"
  status=1
else
  echo "static-checks: clang-tidy: ${#sources[@]} files clean (${tidy_s} s)"
fi

# cppcheck: the same translation units. Its --file-filter matches the paths as cppcheck prints
# them, relative to here when the project file is named relative to here.
start=$(date +%s)
mkdir -p "$build/cppcheck"
cppcheck --project="$(realpath --relative-to="$root" "$build/compile_commands.json")" \
  --file-filter='core/*' \
  --enable=warning,performance,portability --std=c++20 --inline-suppr \
  --suppressions-list="$root/.cppcheck-suppressions" --cppcheck-build-dir="$build/cppcheck" \
  --error-exitcode=1 --quiet -j "$jobs" 2>"$logs/cppcheck.txt"
cppcheck_status=$?
cppcheck_s=$(( $(date +%s) - start ))
if [ "$cppcheck_status" -ne 0 ] || [ -s "$logs/cppcheck.txt" ]; then
  cat "$logs/cppcheck.txt"
  echo "static-checks: cppcheck: findings (${cppcheck_s} s)"
  status=1
else
  echo "static-checks: cppcheck: clean (${cppcheck_s} s)"
fi
exit "$status"
