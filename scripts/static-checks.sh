#!/usr/bin/env bash
# Static checks (docs/quality.md): clang-format on every C++ file (the committed .clang-format);
# the include order of core's and ui's folders (scripts/include-order.py); on core/, clang-tidy
# with the committed .clang-tidy, and cppcheck (warning, performance, portability) with the
# committed .cppcheck-suppressions.
# Fails (exit 1) on any finding of any; prints each tool's findings and run time.
#   scripts/static-checks.sh [BUILD_DIR]      BUILD_DIR holds compile_commands.json (default build)
#   JOBS=N scripts/static-checks.sh           N clang-tidy/cppcheck processes at once (default 1)
#   FILES="core/a.cpp core/b.cpp" scripts/...  clang-tidy and cppcheck on these files only
#   FINGERPRINT=1 scripts/static-checks.sh    prints the fingerprint of core/'s compile flags (the
#                                             second line of .ci/static-checks-base)
# Needs: clang-format, clang-tidy, cppcheck (Debian packages of those names), a configured build.
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
for tool in clang-tidy cppcheck clang-format; do
  command -v "$tool" >/dev/null || { echo "static-checks: $tool is not installed" >&2; exit 2; }
done
cd "$root"
# The compile commands unit by unit: a build that compiles core/ in unity batches
# (GREYBENCH_UNITY_CORE, which scripts/dev.sh turns on) records one command per batch; each of the
# batch's units gets that command with its own source and object, as a build without batches
# records it (the same flags, so the same fingerprint below). `unity_object` names its batch.
db=$build/static-db
mkdir -p "$db"
python3 - "$build" "$root" "$db/compile_commands.json" <<'PY'
import json, os, re, sys
build, root, out = sys.argv[1:4]
entries = []
for e in json.load(open(os.path.join(build, "compile_commands.json"))):
    if not re.search(r"/greybench_core\.dir/Unity/unity_\d+_cxx\.cxx$", e["file"]):
        entries.append(e)
        continue
    unity_object = os.path.relpath(e["file"], build) + ".o"
    for src in re.findall(r'#include "([^"]+)"', open(e["file"]).read()):
        obj = "core/CMakeFiles/greybench_core.dir/" + os.path.relpath(src, os.path.join(root, "core")) + ".o"
        command = e["command"].replace(unity_object, obj).replace(e["file"], src)
        entries.append({"directory": e["directory"], "command": command, "file": src,
                        "unity_object": unity_object})
json.dump(entries, open(out, "w"), indent=1)
PY
# The compile flags of core/'s units in this build (each unit's command without its own source
# and object, paths relative to the tree), distinct and sorted, hashed.
flags_fingerprint() {
  python3 - "$db/compile_commands.json" "$root" <<'PY'
import hashlib, json, shlex, sys
root = sys.argv[2].rstrip("/")
flags = set()
for entry in json.load(open(sys.argv[1])):
    if not entry["file"].startswith(root + "/core/"):
        continue
    args, skip = [], False
    for a in shlex.split(entry["command"]):
        if skip:
            skip = False
        elif a in ("-o", "-c"):
            skip = True
        else:
            args.append(a.replace(root, "."))
    flags.add(" ".join(args))
print(hashlib.sha256("\n".join(sorted(flags)).encode()).hexdigest()[:16])
PY
}
if [ "${FINGERPRINT:-}" = 1 ]; then
  flags_fingerprint
  exit 0
fi
if [ -n "${FILES:-}" ]; then
  read -r -a sources <<<"$FILES"
else
  mapfile -t sources < <(git ls-files 'core/*.cpp')
  # Incremental, and sound: clang-tidy's and cppcheck's findings on a translation unit depend
  # only on its sources and the configuration, so after a commit whose full check passed
  # (.ci/static-checks-base), only the units whose .cpp or any header they include (the build's
  # own dependency record, ninja -t deps; scripts/changed_units.py) changed since are checked
  # again; everything when the
  # configuration changed (.clang-tidy, or the compile flags of core/'s units), or the base is
  # not in the history. The base file's first line is the commit; its second, when there, the
  # flags' fingerprint at that commit (`FINGERPRINT=1 scripts/static-checks.sh`): with it a change
  # of a CMake file that leaves core/'s flags as they were checks only what changed; without it
  # any change of a CMakeLists.txt checks everything. STATIC_CHECKS_ALL=1 checks every file.
  base_file=$root/.ci/static-checks-base
  if [ -z "${STATIC_CHECKS_ALL:-}" ] && [ -f "$base_file" ]; then
    base=$(sed -n 1p "$base_file" | tr -d '[:space:]')
    base_flags=$(sed -n 2p "$base_file" | tr -d '[:space:]')
    if git cat-file -e "$base^{commit}" 2>/dev/null; then
      changed=$(git diff --name-only "$base" HEAD)
      config='\.clang-tidy|CMakeLists\.txt|core/CMakeLists\.txt'
      if [ -n "$base_flags" ] && [ "$base_flags" = "$(flags_fingerprint)" ]; then
        config='\.clang-tidy'
      fi
      if ! grep -qxE "$config" <<<"$changed"; then
        mapfile -t selected < <(printf '%s\n' "$changed" |
          python3 "$root/scripts/changed_units.py" "$build" "$root" "${sources[@]}")
        echo "static-checks: ${#selected[@]} of ${#sources[@]} files changed (with their headers) since $base, whose full check passed"
        sources=("${selected[@]}")
      fi
    fi
  fi
fi
logs=$(mktemp -d)
trap 'rm -rf "$logs"' EXIT
status=0

# clang-format: every C++ file git tracks is as the committed .clang-format lays it out (a few
# seconds; `clang-format -i FILE` fixes one). Not incremental: it is cheap.
start=$(date +%s)
git ls-files '*.cpp' '*.h' |
  xargs -P "$jobs" -n 40 clang-format --dry-run --Werror >"$logs/format.txt" 2>&1
format_s=$(( $(date +%s) - start ))
if [ -s "$logs/format.txt" ]; then
  grep -E '^[^ ].*: error:' "$logs/format.txt" | sed -E 's/:[0-9]+:[0-9]+: error:.*//' | sort -u |
    sed 's/^/static-checks: clang-format: not formatted: /'
  echo "static-checks: clang-format: findings (${format_s} s; clang-format -i FILE lays one out)"
  status=1
else
  echo "static-checks: clang-format: $(git ls-files '*.cpp' '*.h' | wc -l) files formatted (${format_s} s)"
fi

# The dependency order of core's and ui's folders (scripts/include-order.py holds it): a back
# edge is a finding, printed FILE:LINE. Well under a second.
if ! python3 "$root/scripts/include-order.py" --root "$root"; then
  status=1
fi

# clang-tidy: one process per file. The compile commands are GCC's; clang does not know some of
# its warning options (-Wno-restrict), which is not a finding.
start=$(date +%s)
printf '%s\n' "${sources[@]}" |
  xargs -P "$jobs" -I{} sh -c 'clang-tidy -p "$1" --quiet --extra-arg=-Wno-unknown-warning-option \
      "$2" >"$3/$(echo "$2" | tr / _).log" 2>&1 || echo "$2" >>"$3/failed"' _ "$db" {} "$logs"
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

# cppcheck: the same translation units (all of core's took 18 minutes at nice 19 beside CI's
# gates, most of them in a few units; four online units take 1.5 s: hence incremental too). Its --file-filter matches the paths as
# cppcheck prints them, relative to here when the project file is named relative to here.
start=$(date +%s)
mkdir -p "$build/cppcheck"
filters=()
for f in "${sources[@]}"; do filters+=("--file-filter=$f"); done
cppcheck_status=0
: >"$logs/cppcheck.txt"
if [ ${#sources[@]} -gt 0 ]; then
  cppcheck --project="$(realpath --relative-to="$root" "$db/compile_commands.json")" \
    "${filters[@]}" \
    --enable=warning,performance,portability --std=c++20 --inline-suppr \
    --suppressions-list="$root/.cppcheck-suppressions" --cppcheck-build-dir="$build/cppcheck" \
    --error-exitcode=1 --quiet -j "$jobs" 2>"$logs/cppcheck.txt"
  cppcheck_status=$?
fi
cppcheck_s=$(( $(date +%s) - start ))
if [ "$cppcheck_status" -ne 0 ] || [ -s "$logs/cppcheck.txt" ]; then
  cat "$logs/cppcheck.txt"
  echo "static-checks: cppcheck: findings (${cppcheck_s} s)"
  status=1
else
  echo "static-checks: cppcheck: ${#sources[@]} files clean (${cppcheck_s} s)"
fi
exit "$status"
