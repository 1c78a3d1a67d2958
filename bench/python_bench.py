#!/usr/bin/python3
"""splitray's Python module against the libraries Python users call instead, in one run.

Rays: splitray.Scene (bvh, kd) against Embree through the same binding (accel="embree", and
builder="medium-robust" for its robust mode) and
Open3D's RaycastingScene (its hit count is reported: Debian's 0.16.1 finds none here, and a
peer that finds nothing is not a valid yardstick). Points: splitray.KDTree against scipy's
cKDTree, k = 8 and query_ball_point, workers=-1 on both. Medians of --runs runs; JSON and
Markdown into --out (default bench/results/python.*).

    PYTHONPATH=build/python /usr/bin/python3 bench/python_bench.py [--runs 3] [--points 1000000]
"""

import argparse
import json
import os
import pathlib
import statistics
import subprocess
import tempfile
import time

import numpy as np
from scipy.spatial import cKDTree

import splitray
from bench_common import ROOT, cpu_model, project_path

BINARY = ROOT / "build" / "apps" / "splitray" / "splitray"




def median_seconds(call, runs):
    times = []
    for _ in range(runs):
        start = time.perf_counter()
        result = call()
        times.append(time.perf_counter() - start)
    return statistics.median(times), result


def interleaved_seconds(calls, runs):
    """Median seconds and result of each named call: a warm-up call each, then `runs` rounds in
    which every call is timed in turn, so that all see the same state of a noisy machine (as
    `splitray bench bvh` does)."""
    results = {name: call() for name, call in calls.items()}
    times = {name: [] for name in calls}
    for _ in range(runs):
        for name, call in calls.items():
            start = time.perf_counter()
            results[name] = call()
            times[name].append(time.perf_counter() - start)
    return {name: (statistics.median(times[name]), results[name]) for name in calls}


def ray_sets(vertices, triangles, n, rng):
    """Rays from around the mesh towards it, and diffuse rays leaving the surface."""
    lo, hi = vertices.min(0), vertices.max(0)
    centre, size = (lo + hi) / 2, hi - lo
    origins = centre + rng.normal(size=(n, 3)) * size
    targets = centre + rng.normal(size=(n, 3)) * size * 0.2
    primary = np.hstack([origins, targets - origins]).astype(np.float32)
    tri = vertices[triangles[rng.integers(0, len(triangles), n)]]
    u, v = rng.random((2, n))
    flip = u + v > 1
    u[flip], v[flip] = 1 - u[flip], 1 - v[flip]
    points = tri[:, 0] + (tri[:, 1] - tri[:, 0]) * u[:, None] + (tri[:, 2] - tri[:, 0]) * v[:, None]
    normal = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    direction = rng.normal(size=(n, 3))
    direction *= np.where((direction * normal).sum(1) < 0, -1.0, 1.0)[:, None]  # away from the face
    offset = 1e-4 * float(np.linalg.norm(size))
    diffuse = np.hstack([points + direction / np.linalg.norm(direction, axis=1, keepdims=True) * offset,
                         direction]).astype(np.float32)
    return {"primary": primary, "diffuse": diffuse}


def bench_rays(path, rays_per_set, runs, rng):
    vertices, triangles = splitray.load_mesh(path)
    rows = []
    scenes = {name: splitray.Scene(vertices, triangles, accel=name) for name in ("bvh", "kd", "embree")}
    # Embree in its robust mode (conservative boxes, a triangle test no ray aimed at an edge
    # passes through): the guarantee nearest to that of every splitray structure.
    scenes["embree_robust"] = splitray.Scene(vertices, triangles, accel="embree", builder="medium-robust")
    try:
        import open3d as o3d
        o3d_scene = o3d.t.geometry.RaycastingScene()
        o3d_scene.add_triangles(o3d.core.Tensor(vertices), o3d.core.Tensor(triangles))
    except ImportError:
        o3d_scene = None
    for kind, rays in ray_sets(vertices, triangles, rays_per_set, rng).items():
        row = {"mesh": project_path(path), "triangles": len(triangles),
               "rays": kind, "count": len(rays)}
        calls = {name: (lambda scene=scene: scene.cast_rays(rays, nthreads=-1)) for name, scene in scenes.items()}
        measured = interleaved_seconds(calls, runs)
        for name in scenes:
            seconds, hits = measured[name]
            row[f"{name}_mrays_s"] = len(rays) / seconds / 1e6
            row[f"{name}_hits"] = int((hits["primitive_ids"] != 2**32 - 1).sum())
        if o3d_scene is not None:
            tensor = o3d.core.Tensor(rays)
            seconds, hits = median_seconds(lambda: o3d_scene.cast_rays(tensor, nthreads=0), runs)
            row["open3d_mrays_s"] = len(rays) / seconds / 1e6
            row["open3d_hits"] = int(np.isfinite(hits["t_hit"].numpy()).sum())
            row["open3d_valid"] = row["open3d_hits"] == row["bvh_hits"]
        row["bvh_vs_embree"] = row["bvh_mrays_s"] / row["embree_mrays_s"]
        row["bvh_vs_embree_robust"] = row["bvh_mrays_s"] / row["embree_robust_mrays_s"]
        # The same rays through the C++ batched call (`splitray trace --rays-in`, tracing timed
        # alone, median of as many repeats): what the Python layer costs.
        with tempfile.TemporaryDirectory() as work:
            npy = pathlib.Path(work) / "rays.npy"
            np.save(npy, rays)
            done = subprocess.run([str(BINARY), "trace", str(path), "--accel", "bvh", "--rays-in", str(npy),
                                   "--repeat", str(runs), "--json"], capture_output=True, text=True, check=True)
        row["cpp_bvh_mrays_s"] = json.loads(done.stdout)["mrays_per_s"]
        row["python_vs_cpp"] = row["bvh_mrays_s"] / row["cpp_bvh_mrays_s"]
        rows.append(row)
    return rows


def bench_points(path, n_points, n_queries, runs, rng):
    vertices, triangles = splitray.load_mesh(path)
    tri = vertices[triangles[rng.integers(0, len(triangles), n_points)]]
    u, v = rng.random((2, n_points))
    flip = u + v > 1
    u[flip], v[flip] = 1 - u[flip], 1 - v[flip]
    points = (tri[:, 0] + (tri[:, 1] - tri[:, 0]) * u[:, None]
              + (tri[:, 2] - tri[:, 0]) * v[:, None]).astype(np.float32)
    queries = points[rng.integers(0, n_points, n_queries)] + rng.normal(size=(n_queries, 3)).astype(np.float32) * 1e-3 * np.ptp(points)
    build_ours, ours = median_seconds(lambda: splitray.KDTree(points, leafsize=10), runs)
    build_theirs, theirs = median_seconds(lambda: cKDTree(points, leafsize=10), runs)
    knn_ours, (d, i) = median_seconds(lambda: ours.query(queries, k=8, workers=-1), runs)
    knn_theirs, (sd, si) = median_seconds(lambda: theirs.query(queries, k=8, workers=-1), runs)
    r = float(np.median(sd[:, 7]))
    ball_ours, found = median_seconds(lambda: ours.query_ball_point(queries, r, workers=-1), runs)
    ball_theirs, _ = median_seconds(lambda: theirs.query_ball_point(queries, r, workers=-1), runs)
    return {"mesh": project_path(path), "points": n_points, "queries": n_queries,
            "build_ms": build_ours * 1e3, "scipy_build_ms": build_theirs * 1e3,
            "knn8_ms": knn_ours * 1e3, "scipy_knn8_ms": knn_theirs * 1e3, "knn8_speedup": knn_theirs / knn_ours,
            "knn8_index_agreement": float((i == si).mean()),
            "ball_ms": ball_ours * 1e3, "scipy_ball_ms": ball_theirs * 1e3, "ball_speedup": ball_theirs / ball_ours,
            "ball_radius": r, "ball_mean_found": float(np.mean([len(x) for x in found]))}


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--runs", type=int, default=3, help="runs per measurement (median)")
    parser.add_argument("--rays", type=int, default=500000, help="rays per ray set")
    parser.add_argument("--points", type=int, default=1000000, help="points of the KDTree")
    parser.add_argument("--queries", type=int, default=200000, help="KDTree queries")
    parser.add_argument("--out", default=str(ROOT / "bench" / "results" / "python"),
                        help="output path without extension (.json and .md are written)")
    args = parser.parse_args()
    rng = np.random.default_rng(1)
    meshes = [ROOT / "data" / "horse" / "horse.obj.gz", ROOT / "data" / "dragon_100k" / "dragon.obj.gz"]
    sibenik = ROOT.parent / "shared" / "data" / "static_sibenik" / "sibenik.obj"
    if sibenik.exists():
        meshes.append(sibenik)
    report = {"cpu": cpu_model(), "cores": os.cpu_count(), "runs": args.runs, "splitray": splitray.__version__,
              "rays": [row for m in meshes for row in bench_rays(m, args.rays, args.runs, rng)],
              "points": bench_points(meshes[1], args.points, args.queries, args.runs, rng)}
    out = pathlib.Path(args.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    tmp = out.with_suffix(".json.tmp")
    tmp.write_text(json.dumps(report, indent=2) + "\n")
    tmp.replace(out.with_suffix(".json"))
    lines = [f"# splitray from Python ({report['cpu']}, {report['cores']} cores, median of {args.runs} runs)", "",
             "| mesh | triangles | rays | bvh Mrays/s | kd Mrays/s | embree Mrays/s | bvh / embree | embree robust Mrays/s | bvh / embree robust | bvh C++ batched Mrays/s | Python / C++ | open3d Mrays/s (hits) |",
             "|---|---:|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|"]
    for r in report["rays"]:
        o3d_text = f"{r['open3d_mrays_s']:.2f} ({r['open3d_hits']} of {r['bvh_hits']})" if "open3d_hits" in r else "n/a"
        lines.append(f"| {r['mesh']} | {r['triangles']} | {r['rays']} | {r['bvh_mrays_s']:.2f} | {r['kd_mrays_s']:.2f} | "
                     f"{r['embree_mrays_s']:.2f} | {r['bvh_vs_embree']:.2f} | {r['embree_robust_mrays_s']:.2f} | "
                     f"{r['bvh_vs_embree_robust']:.2f} | {r['cpp_bvh_mrays_s']:.2f} | "
                     f"{r['python_vs_cpp']:.2f} | {o3d_text} |")
    p = report["points"]
    lines += ["", "| points | queries | build ms (scipy) | k=8 ms (scipy) | k=8 speed-up | ball ms (scipy) | ball speed-up |",
              "|---:|---:|---:|---:|---:|---:|---:|",
              f"| {p['points']} | {p['queries']} | {p['build_ms']:.0f} ({p['scipy_build_ms']:.0f}) | {p['knn8_ms']:.0f} "
              f"({p['scipy_knn8_ms']:.0f}) | {p['knn8_speedup']:.2f} | {p['ball_ms']:.0f} ({p['scipy_ball_ms']:.0f}) | "
              f"{p['ball_speedup']:.2f} |"]
    md = out.with_suffix(".md.tmp")
    md.write_text("\n".join(lines) + "\n")
    md.replace(out.with_suffix(".md"))
    print("\n".join(lines))


if __name__ == "__main__":
    main()
