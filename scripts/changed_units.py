#!/usr/bin/env python3
"""The units of core/ whose source or any header they include changed (scripts/static-checks.sh).

  changed_units.py BUILD_DIR ROOT UNIT... < CHANGED_FILES

Prints, one per line, each UNIT (core/x/y.cpp) that is among the changed files (paths relative
to ROOT, read from stdin) or includes one. A unit's headers come from the build's own dependency
record (ninja -t deps) of its object; a unit compiled in a unity batch (BUILD_DIR/static-db's
compile commands name the batch's object) is looked up in its batch's record, which holds every
unit of the batch, and only when that touches a changed file are its own headers listed, by the
compiler (its command with -MM). A unit with no record at all is printed (checked, to be safe).
"""
import json
import os
import shlex
import subprocess
import sys


def ninja_deps(build, root, obj):
    out = subprocess.run(["ninja", "-C", build, "-t", "deps", obj], capture_output=True,
                         text=True, check=False).stdout.splitlines()
    deps = set()
    for line in out[1:]:
        path = line.strip()
        if path:  # absolute, or relative to the build directory (as ccache's base dir writes it)
            deps.add(os.path.relpath(os.path.join(os.path.abspath(build), path), root))
    return deps


def own_deps(entry, root):
    """The files one unit includes, by its compile command with -MM (no system headers)."""
    args = shlex.split(entry["command"])
    kept, skip = [], False
    for a in args:
        if skip:
            skip = False
        elif a in ("-o", "-MT", "-MF", "-c"):
            skip = a != "-c"
        elif a not in ("-MD", "-MMD", entry["file"]):
            kept.append(a)
    out = subprocess.run(kept + ["-MM", entry["file"]], cwd=entry["directory"],
                         capture_output=True, text=True, check=False)
    if out.returncode != 0:
        return None
    words = out.stdout.replace("\\\n", " ").split()[1:]
    return {os.path.relpath(os.path.join(entry["directory"], w), root) for w in words}


def main():
    build, root, units = sys.argv[1], sys.argv[2], sys.argv[3:]
    changed = {line.strip() for line in sys.stdin if line.strip()}
    entries = {os.path.relpath(e["file"], root): e
               for e in json.load(open(os.path.join(build, "static-db", "compile_commands.json")))}
    batch_deps = {}
    for unit in units:
        entry = entries.get(unit)
        if entry is None:
            print(unit)
            continue
        if "unity_object" in entry:
            obj = entry["unity_object"]
            if obj not in batch_deps:
                batch_deps[obj] = ninja_deps(build, root, obj)
            batch = batch_deps[obj]  # a superset of the unit's own headers
            deps = own_deps(entry, root) if batch & (changed | {unit}) else batch
        else:
            deps = ninja_deps(build, root, f"core/CMakeFiles/greybench_core.dir/{unit[5:]}.o")
        if not deps or (deps | {unit}) & changed:
            print(unit)


if __name__ == "__main__":
    main()
