#!/usr/bin/python3
"""Peak memory of building a splitray.Scene from NumPy arrays of over 10^6 triangles (the
vendored dragon subdivided twice: 1.6 M triangles), per structure, against the caller's arrays
and the structure's own size, with Embree through the same binding as the yardstick. Every
structure is built in a fresh process; the peak resident set before and after the build gives
what the build added. JSON and Markdown into --out (default bench/results/python_memory.*).

    PYTHONPATH=build/python /usr/bin/python3 bench/python_memory.py
"""

import argparse
import json
import os
import pathlib
import subprocess
import sys

from bench_common import ROOT, cpu_model, project_path

MESH = ROOT / "data" / "dragon_100k" / "dragon.obj.gz"

CHILD = r"""
import json, resource, sys
import numpy as np
import splitray

def subdivide(v, f):
    # Every triangle into four through its edge midpoints (vertices shared between neighbours).
    edges = np.sort(np.concatenate([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]]), axis=1)
    unique, inverse = np.unique(edges, axis=0, return_inverse=True)
    mid = (v[unique[:, 0]] + v[unique[:, 1]]) * 0.5
    m = (inverse.reshape(3, -1).T + len(v)).astype(np.uint32)
    a, b, c = f[:, 0], f[:, 1], f[:, 2]
    faces = np.concatenate([np.stack([a, m[:, 0], m[:, 2]], 1), np.stack([m[:, 0], b, m[:, 1]], 1),
                            np.stack([m[:, 2], m[:, 1], c], 1), np.stack([m[:, 0], m[:, 1], m[:, 2]], 1)])
    return np.ascontiguousarray(np.concatenate([v, mid]).astype(np.float32)), np.ascontiguousarray(faces)

v, f = splitray.load_mesh(sys.argv[1])
for _ in range(2):
    v, f = subdivide(v, f)
peak_kib = lambda: resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
before = peak_kib()
scene = splitray.Scene(v, f, accel=sys.argv[2])
after = peak_kib()
stats = scene.stats
print(json.dumps({"accel": sys.argv[2], "triangles": int(len(f)), "vertices": int(len(v)),
                  "input_bytes": int(v.nbytes + f.nbytes), "peak_added_bytes": (after - before) * 1024,
                  "structure_bytes": int(stats["bytes"]), "build_ms": stats["build_ms"]}))
"""


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--out", default=str(ROOT / "bench" / "results" / "python_memory"))
    options = parser.parse_args()
    rows = []
    for accel in ("bvh", "kd", "bih", "embree"):
        done = subprocess.run([sys.executable, "-c", CHILD, str(MESH), accel], capture_output=True,
                              text=True, env=os.environ)
        if done.returncode != 0:
            raise SystemExit(f"{accel}: {done.stderr}")
        rows.append(json.loads(done.stdout))
    cpu = cpu_model()
    report = {"cpu": cpu, "mesh": project_path(MESH) + " subdivided twice", "rows": rows}
    out = pathlib.Path(options.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    out.with_suffix(".json").write_text(json.dumps(report, indent=2) + "\n")
    mib = 1 << 20
    lines = [f"# Building a Scene from NumPy: peak memory ({cpu})", "",
             f"{report['mesh']}: {rows[0]['triangles']} triangles, {rows[0]['vertices']} vertices, "
             f"arrays {rows[0]['input_bytes'] / mib:.1f} MiB.", "",
             "| accel | build ms | peak added MiB | structure MiB | peak added / arrays |",
             "|---|---:|---:|---:|---:|"]
    for r in rows:
        structure = f"{r['structure_bytes'] / mib:.1f}" if r["structure_bytes"] else "n/a"
        lines.append(f"| {r['accel']} | {r['build_ms']:.0f} | {r['peak_added_bytes'] / mib:.1f} | "
                     f"{structure} | {r['peak_added_bytes'] / r['input_bytes']:.1f}x |")
    out.with_suffix(".md").write_text("\n".join(lines) + "\n")
    print("\n".join(lines))


if __name__ == "__main__":
    main()
