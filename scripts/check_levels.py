#!/usr/bin/env python3
"""Fails when the library's modules depend on each other in a cycle (issue #25, Lakos's
levelization): a module is a .hpp/.cpp pair under src/splitray, and it depends on every
module whose header its header or source includes. Prints each cycle and exits 1.

Usage: scripts/check_levels.py [SOURCE_ROOT]   (default: src of this checkout)"""
import os
import re
import sys


def module_graph(src):
    graph = {}
    for folder, _, files in os.walk(os.path.join(src, "splitray")):
        for name in files:
            if not name.endswith((".hpp", ".cpp")):
                continue
            path = os.path.join(folder, name)
            module = os.path.relpath(path, src)[:-4]
            with open(path, encoding="utf-8") as f:
                includes = re.findall(r'#include "(splitray/[^"]+)\.hpp"', f.read())
            graph.setdefault(module, set()).update(i for i in includes if i != module)
    return graph


def cycles(graph):
    """Strongly connected components of more than one module (Tarjan, iterative)."""
    index, low, on_stack, stack, found, counter = {}, {}, set(), [], [], [0]
    for start in sorted(graph):
        if start in index:
            continue
        work = [(start, iter(sorted(graph.get(start, ()))))]
        index[start] = low[start] = counter[0]
        counter[0] += 1
        stack.append(start)
        on_stack.add(start)
        while work:
            node, children = work[-1]
            child = next(children, None)
            if child is not None:
                if child not in index:
                    index[child] = low[child] = counter[0]
                    counter[0] += 1
                    stack.append(child)
                    on_stack.add(child)
                    work.append((child, iter(sorted(graph.get(child, ())))))
                elif child in on_stack:
                    low[node] = min(low[node], index[child])
                continue
            work.pop()
            if work:
                low[work[-1][0]] = min(low[work[-1][0]], low[node])
            if low[node] == index[node]:
                component = []
                while True:
                    member = stack.pop()
                    on_stack.discard(member)
                    component.append(member)
                    if member == node:
                        break
                if len(component) > 1:
                    found.append(sorted(component))
    return found


def main():
    src = sys.argv[1] if len(sys.argv) > 1 else os.path.join(os.path.dirname(__file__), "..", "src")
    graph = module_graph(src)
    if not graph:
        print(f"check_levels: no modules under {src}/splitray", file=sys.stderr)
        return 1
    found = cycles(graph)
    for component in found:
        print("check_levels: modules that include each other: " + " <-> ".join(component),
              file=sys.stderr)
    print(f"check_levels: {len(graph)} modules, {len(found)} cycles")
    return 1 if found else 0


if __name__ == "__main__":
    sys.exit(main())
