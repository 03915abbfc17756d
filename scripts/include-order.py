#!/usr/bin/env python3
"""The dependency order of core's folders, checked (docs/STYLE: "core's folders include only
folders below them, and a script in CI says so").

ORDER below is the one place the order is written, lowest first: a folder may include its own
files and those of the folders on lower lines, nothing on its own line or above. Folders on one
line do not include each other. Every `#include "core/..."` in core/ is compared with it; a back
edge fails the check (exit 1), printed as

  FILE:LINE: core/X includes core/Y, which is above it in the order

  scripts/include-order.py [--root DIR]   checks DIR (default: the tree holding this script)
  scripts/include-order.py --picture      prints the order as the README draws it

Called by scripts/static-checks.sh (CI's static gate) and by the test `scripts.include-order`.
Python 3 standard library only; reads the files once (well under a second).
"""
import argparse
import os
import re
import sys

# Lowest first. Each line: its folders (one level), and what they hold (for --picture).
ORDER = [
    ("core/util", "results and errors, files, JSON, threads"),
    ("core/expr", "expressions: parse, simplify, differentiate, tape"),
    ("core/data", "datasets: CSV, MDF 4, import, bind, follow a growing file"),
    ("core/model", "model files: linear and nonlinear models, linearisation"),
    ("core/ode", "the error-controlled ODE solver (explicit and BDF)"),
    ("core/filter", "discretise; Kalman filter, EKF, their scores; the likelihood"),
    ("core/estimate core/design core/diagnose",
     "fitting, profiles; input design (PRBS); residual tests"),
    ("core/online core/sim core/report",
     "on-line estimation and monitoring; simulation, dyno; reports"),
    ("core/fmu", "the fitted model as an FMI 2.0 FMU"),
    ("core/project", "project and result files, problems, sweeps, operating points"),
    ("core/diagram", "block diagrams of a project's model"),
    # ui/ (greybench_ui), above all of core. A file at the top of ui/ is a unit of its own.
    ("ui/format ui/render ui/edits",
     "numbers as printed; frames to PNG; model and diagram edits"),
    ("ui/widgets", "plot, node editor, heat map, file browser"),
    ("ui/jobs", "background work: estimation, analysis, sweep, live"),
    ("ui/state", "AppState, the views' states, the jobs' life in it"),
    ("ui/theme ui/export", "fonts and colours; exports through the file browser"),
    ("ui/panels", "one file a view"),
    ("ui/shell", "menus, dialogs, saving, recovery"),
    ("ui/workbench", "the frame: menu bar, sidebar, current view"),
]

INCLUDE = re.compile(r'^\s*#\s*include\s*"((?:core|ui)/[^"]+)"')


def levels():
    """folder -> its line in ORDER (0 lowest)."""
    level = {}
    for i, (folders, _) in enumerate(ORDER):
        for f in folders.split():
            level[f] = i
    return level


def folder_of(path):
    """core/filter/kalman.h -> core/filter; ui/format.h -> ui/format (a file at the top)."""
    parts = path.split("/")
    return "/".join(parts[:2]) if len(parts) > 2 else os.path.splitext(path)[0]


def check(root):
    level = levels()
    errors, edges, files = [], 0, 0
    for top in ("core", "ui"):
        for dirpath, dirnames, filenames in os.walk(os.path.join(root, top)):
            dirnames.sort()
            for name in sorted(filenames):
                if not name.endswith((".h", ".cpp")):
                    continue
                path = os.path.join(dirpath, name)
                rel = os.path.relpath(path, root).replace(os.sep, "/")
                src = folder_of(rel)
                files += 1
                if src not in level:
                    errors.append(f"{rel}:1: {src} is not in the order (scripts/include-order.py)")
                    continue
                with open(path, encoding="utf-8", errors="replace") as f:
                    for n, line in enumerate(f, 1):
                        m = INCLUDE.match(line)
                        if not m:
                            continue
                        dst = folder_of(m.group(1))
                        if dst == src:
                            continue
                        edges += 1
                        if dst not in level:
                            errors.append(f"{rel}:{n}: {src} includes {dst}, which is not in the "
                                          "order")
                        elif level[dst] == level[src]:
                            errors.append(f"{rel}:{n}: {src} includes {dst}, which is beside it "
                                          "in the order")
                        elif level[dst] > level[src]:
                            errors.append(f"{rel}:{n}: {src} includes {dst}, which is above it "
                                          "in the order")
    return errors, edges, files


def short(folders):
    """"core/online core/sim" -> "online, sim" (each part of the picture names its own top)."""
    return ", ".join(f.split("/", 1)[1] for f in folders.split())


def picture():
    """The order as text, highest first, as a stack reads: each line includes only lines below."""
    out = []
    for top in ("ui", "core"):
        rows = [(f, what) for f, what in ORDER if f.startswith(top + "/")]
        width = max(len(short(f)) for f, _ in rows)
        out.append(f"{top}/" + (" (above all of core/)" if top == "ui" else ""))
        for folders, what in reversed(rows):
            out.append(f"  {short(folders):<{width}}  {what}")
    return "\n".join(out)


def main():
    here = os.path.dirname(os.path.abspath(__file__))
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--root", default=os.path.dirname(here), help="the source tree")
    parser.add_argument("--picture", action="store_true", help="print the order and exit")
    args = parser.parse_args()
    if args.picture:
        print(picture())
        return 0
    errors, edges, files = check(args.root)
    for e in errors:
        print(e)
    order = "; ".join(f"{top}/ " + " < ".join(short(f).replace(", ", "/") for f, _ in ORDER
                                              if f.startswith(top + "/"))
                      for top in ("core", "ui"))
    if errors:
        print(f"include-order: {len(errors)} include(s) against the order {order} "
              "(scripts/include-order.py)")
        return 1
    print(f"include-order: {edges} includes between folders ({files} files) follow {order}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
