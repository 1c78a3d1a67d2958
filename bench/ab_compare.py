#!/usr/bin/python3
"""A/B of two splitray binaries on the same meshes, in one run: what a change did to the trees
(SAH cost, references, nodes: deterministic) and to build and trace speed (medians of
alternating runs, so that both see the same machine load).

    bench/ab_compare.py OLD/splitray NEW/splitray [--meshes M ...] [--structures kd:golden ...]
        [--runs 5] [--trace primary,diffuse] [--rays 262144] [--threads 1] [--json FILE]

Meshes default to every benchmark mesh (`splitray bench build-trace`'s list, found through the
shared data beside the checkout); a path is taken as a mesh file. Prints a Markdown table:
new / old for each figure (1.000 = unchanged; build and trace time ratios below 1 are faster).
"""
import argparse
import json
import os
import platform
import statistics
import subprocess
import sys

SHARED = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "shared", "data")
MESHES = {
    "horse": "data/horse/horse.obj.gz",
    "dragon": "data/dragon_100k/dragon.obj.gz",
    "sibenik": "@static_sibenik/sibenik.obj",
    "cornell_box": "@static_cornell_box/cornell_box.obj",
    "cat": "@static_sumner_cat_lion_poses/cat-poses/cat-reference.obj.gz",
    "lion": "@static_sumner_cat_lion_poses/lion-poses/lion-reference.obj.gz",
    "elephant": "@anim_elephant_gallop/frames/elephant-gallop-01.obj.gz",
    "samba": "@anim_samba/frames/samba_0000.obj.gz",
    "walking_cat": "@anim_walking_cat/frames/mesh.01.obj",
    "faerie": "@anim_md2_faerie/frames/faerie_000.obj",
    "armadillo_rollers": "@anim_ccd_frame_pairs/armadillo-rollers/frames/326.ply",
    "cloth_funnel": "@anim_ccd_frame_pairs/cloth-funnel/frames/227.ply",
    "rod_twist": "@anim_ccd_frame_pairs/rod-twist/frames/3036.ply",
    "n_body": "@anim_ccd_frame_pairs/n-body-simulation/frames/balls16_18.ply",
}
ROOT = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..")


def mesh_path(name):
    if name not in MESHES:
        return name
    p = MESHES[name]
    return os.path.join(SHARED, p[1:]) if p.startswith("@") else os.path.join(ROOT, p)


def run(binary, args):
    out = subprocess.run([binary] + args + ["--json"], check=True, capture_output=True, text=True)
    return json.loads(out.stdout)


def cpu_model():
    try:
        with open("/proc/cpuinfo") as f:
            for line in f:
                if line.startswith("model name"):
                    return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or "unknown"


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("old")
    ap.add_argument("new")
    ap.add_argument("--meshes", nargs="+", default=list(MESHES))
    ap.add_argument("--structures", nargs="+", default=["kd:sah", "kd:golden", "kd:binned"],
                    help="accel:builder pairs")
    ap.add_argument("--runs", type=int, default=5)
    ap.add_argument("--trace", default="", help="ray kinds to trace too, e.g. primary,diffuse")
    ap.add_argument("--rays", type=int, default=262144)
    ap.add_argument("--threads", type=int, default=1)
    ap.add_argument("--json", help="also write the rows to this file")
    a = ap.parse_args()
    kinds = [k for k in a.trace.split(",") if k]
    rows = []
    print(f"CPU: {cpu_model()}; {a.runs} alternating runs, -t {a.threads}", file=sys.stderr)
    print("| mesh | structure | SAH cost new/old | refs new/old | build ms old | build new/old |"
          + "".join(f" {k} Mrays/s old | {k} new/old |" for k in kinds))
    print("|---|---|---|---|---|---|" + "---|---|" * len(kinds))
    for name in a.meshes:
        path = mesh_path(name)
        if not os.path.exists(path):
            print(f"ab_compare: {name}: {path} is absent; skipped", file=sys.stderr)
            continue
        for structure in a.structures:
            accel, builder = structure.split(":")
            common = [path, "--accel", accel, "--builder", builder, "-t", str(a.threads)]
            builds = {"old": [], "new": []}
            traces = {(v, k): [] for v in ("old", "new") for k in kinds}
            stats = {}
            for _ in range(a.runs):
                for which, binary in (("old", a.old), ("new", a.new)):
                    s = run(binary, ["build"] + common)
                    stats[which] = s
                    builds[which].append(s["build_ms"])
                    for k in kinds:
                        t = run(binary, ["trace"] + common + ["--kind", k, "--rays", str(a.rays)])
                        traces[(which, k)].append(t["mrays_per_s"])
            row = {"mesh": name, "structure": structure}
            for key in ("sah_cost", "prim_refs", "nodes"):
                o, n = stats["old"].get(key), stats["new"].get(key)
                row[key] = {"old": o, "new": n}
            row["build_ms"] = {v: statistics.median(builds[v]) for v in builds}
            for k in kinds:
                row[k] = {v: statistics.median(traces[(v, k)]) for v in ("old", "new")}
            rows.append(row)

            def ratio(d):
                return f"{d['new'] / d['old']:.3f}" if d["old"] else "n/a"
            line = (f"| {name} | {structure} | {ratio(row['sah_cost'])} | {ratio(row['prim_refs'])} "
                    f"| {row['build_ms']['old']:.1f} | {ratio(row['build_ms'])} |")
            for k in kinds:
                line += f" {row[k]['old']:.2f} | {ratio(row[k])} |"
            print(line, flush=True)
    if a.json:
        with open(a.json, "w") as f:
            json.dump({"cpu": cpu_model(), "runs": a.runs, "threads": a.threads, "rows": rows}, f,
                      indent=1)


if __name__ == "__main__":
    main()
