#!/usr/bin/env python3
"""Checks that the include graph of core/'s folders (one folder per stage) has no cycle, that no
core file includes Qt, and that no folder includes one that FORBIDDEN keeps it from. Prints each
folder's dependencies, and a cycle if there is one.
Usage: check_core_includes.py REPO_ROOT. Exit status 1 on a cycle, a Qt include or a forbidden
dependency."""
import os
import re
import sys

root = os.path.join(sys.argv[1], "core")
include = re.compile(r'^\s*#\s*include\s+[<"]([^">]+)[">]', re.M)
graph = {}
bad = []
# Dependencies that must not exist, with the reason. Bake turns any accepted probe set into a
# volume, whatever placed it; the runtime reader is one file an engine copies.
FORBIDDEN = {
    "bake": ({"placement"}, "bake works on any probe set, whatever method placed it"),
    "runtime": (None, "the runtime reader is self-contained (an engine copies the one file)"),
}
for folder in sorted(os.listdir(root)):
    path = os.path.join(root, folder)
    if not os.path.isdir(path):
        continue
    deps = graph.setdefault(folder, set())
    for name in sorted(os.listdir(path)):
        text = open(os.path.join(path, name), encoding="utf-8").read()
        for target in include.findall(text):
            if target.startswith("Q") or target.startswith("qt"):
                bad.append(f"core/{folder}/{name} includes Qt ({target})")
            parts = target.split("/")
            if len(parts) >= 3 and parts[0] == "core" and parts[1] != folder:
                deps.add(parts[1])

for folder, deps in sorted(graph.items()):
    print(f"{folder} -> {', '.join(sorted(deps)) or '(nothing)'}")
    if folder in FORBIDDEN:
        banned, why = FORBIDDEN[folder]
        for dep in sorted(deps):
            if banned is None or dep in banned:
                bad.append(f"core/{folder} depends on core/{dep}: {why}")

# Depth-first search for a back edge.
state = {}
stack = []


def visit(node):
    state[node] = "open"
    stack.append(node)
    for dep in sorted(graph.get(node, ())):
        if state.get(dep) == "open":
            return stack[stack.index(dep):] + [dep]
        if dep not in state:
            cycle = visit(dep)
            if cycle:
                return cycle
    stack.pop()
    state[node] = "done"
    return None


for folder in sorted(graph):
    if folder not in state:
        cycle = visit(folder)
        if cycle:
            bad.append("include cycle between core's folders: " + " -> ".join(cycle))
            break

for line in bad:
    print("error: " + line, file=sys.stderr)
sys.exit(1 if bad else 0)
