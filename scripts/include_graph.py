#!/usr/bin/env python3
"""The include graph of exoid's production code by folder, from the sources (docs/architecture.md).

Prints one line per folder: the other folders whose headers it includes. With --check, exits 1 (naming each
edge) when a folder includes one it must not: the ground floor (common, interfaces, model, lcmtypes) includes
only the ground floor below it; sim, controller and estimator stand side by side on it and include none of each
other; the recorded-data intake (estimator/intake) sits on the estimator. The process mains (*/apps), render/ and
tools/ are on top and may include any of them. Tests, benches and fuzz targets are not production code.

usage: scripts/include_graph.py [--check] [ROOT]
"""
import os
import re
import sys

# Folder of a path (relative to the root); None for what is not production code.
SPLIT = {"estimator": ("intake", "apps"), "controller": ("plugin", "apps"), "sim": ("apps",), "tools": ()}


def folder(path):
    parts = path.split("/")
    if parts[0] in ("tests", "bench", "fuzz", "build", "build-sanitize", "scripts", "docs", "data", "config", "cmake") \
            or "tests" in parts or "bench" in parts or "examples" in parts or parts[0].startswith("."):
        return None
    if len(parts) > 2 and parts[1] in SPLIT.get(parts[0], ()):
        return parts[0] + "/" + parts[1]
    return parts[0] if len(parts) > 1 else None


# What each folder may include (besides itself); None: anything (the top).
GROUND = ["common", "interfaces", "model", "lcmtypes"]
ALLOWED = {
    "common": [],
    "interfaces": ["common"],
    "model": ["common", "interfaces"],
    "lcmtypes": ["common", "interfaces"],
    "sim": GROUND,
    "controller": GROUND,
    "controller/plugin": GROUND + ["controller"],
    "estimator": GROUND,
    "estimator/intake": GROUND + ["estimator"],
}


def graph(root):
    headers = {}  # include name -> folder
    sources = []
    for d, dirs, files in os.walk(root):
        dirs[:] = [x for x in dirs if not x.startswith(".") and not x.startswith("build")]
        for f in files:
            rel = os.path.relpath(os.path.join(d, f), root)
            top = folder(rel)
            if top is None or not f.endswith((".hpp", ".h", ".cpp", ".c")):
                continue
            sources.append((rel, top))
            m = re.search(r"/include/(.+)$", rel)
            if m and f.endswith((".hpp", ".h")):
                headers[m.group(1)] = top
    edges = {}
    for rel, top in sources:
        with open(os.path.join(root, rel), errors="replace") as fh:
            for line in fh:
                m = re.match(r'\s*#\s*include\s+"([^"]+)"', line)
                if m and m.group(1) in headers and headers[m.group(1)] != top:
                    edges.setdefault(top, {}).setdefault(headers[m.group(1)], rel)
    return edges


def main():
    args = [a for a in sys.argv[1:] if a != "--check"]
    root = args[0] if args else os.path.join(os.path.dirname(os.path.abspath(__file__)), "..")
    edges = graph(root)
    bad = []
    for top in sorted(edges):
        print(f"{top:18} -> {', '.join(sorted(edges[top]))}")
        allowed = ALLOWED.get(top)
        if allowed is None:
            continue
        for to, where in sorted(edges[top].items()):
            if to not in allowed:
                bad.append(f"{top} includes {to} ({where}); allowed: {', '.join(allowed) or 'nothing of the project'}")
    if "--check" in sys.argv:
        for b in bad:
            print("layering: " + b, file=sys.stderr)
        return 1 if bad else 0
    return 0


if __name__ == "__main__":
    sys.exit(main())
