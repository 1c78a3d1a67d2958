#!/usr/bin/env python3
"""Frame time of every animation strategy on every shared animated sequence (issue #20).

Runs `splitray animate SEQUENCE --compare --json` on each sequence (the same frames for every
strategy, in a rotating order) and writes one JSON with every run and a Markdown table of the
median update / trace / frame ms per strategy, naming the CPU and the command.

  bench/animate_compare.py [--splitray build/apps/splitray/splitray] [--frames N] [-t 2]
                           [--out bench/results/animate_compare]
"""

import argparse
import json
import os
import pathlib
import subprocess
import sys
import tempfile

from bench_common import ROOT, cpu_model, project_path

SHARED = ROOT.parent / "shared" / "data"
# Every shared animated sequence, as `splitray animate` takes it.
SEQUENCES = [
    ("anim_horse_collapse", "anim_horse_collapse/frames/horse-collapse-%02d.obj.gz"),
    ("anim_samba", "anim_samba/frames/samba_%04d.obj.gz"),
    ("anim_elephant_gallop", "anim_elephant_gallop/frames/elephant-gallop-%02d.obj.gz"),
    ("anim_walking_cat", "anim_walking_cat/frames/mesh.%02d.obj"),
    ("anim_bart_museum", "anim_bart_museum/aff/museum5.aff"),
    ("anim_bart_robots", "anim_bart_robots/aff/Robot.aff"),
    ("anim_md2_faerie", "anim_md2_faerie/faerie.md2"),
]
STRATEGIES = ["kd-coherent", "kd-rebuild", "bvh-refit", "bvh-rebuild", "embree-refit",
              "embree-low", "embree-medium"]


def find_input(relative):
    path = SHARED / relative
    return path if (path.parent if "%" in relative else path).exists() else None


def write_atomic(path, text):
    path = pathlib.Path(path)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=path.name + ".")
    with os.fdopen(fd, "w") as f:
        f.write(text)
    os.replace(tmp, path)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--splitray", default=str(ROOT / "build/apps/splitray/splitray"),
                        type=lambda s: str(pathlib.Path(s).resolve()))
    parser.add_argument("--frames", type=int, default=0, help="first N frames (0 = all)")
    parser.add_argument("-t", "--threads", type=int, default=2)
    parser.add_argument("--out", default=str(ROOT / "bench/results/animate_compare"))
    args = parser.parse_args()

    runs = {}
    for name, relative in SEQUENCES:
        path = find_input(relative)
        if path is None:
            print(f"{name}: not found under {SHARED}, skipped", file=sys.stderr)
            continue
        # Relative to the checkout, so that the JSON names no machine path.
        command = [args.splitray, "animate", project_path(path), "--compare", "--json",
                   "-t", str(args.threads), "--frames", str(args.frames)]
        print(f"{name}: {' '.join(command[1:])}", file=sys.stderr, flush=True)
        result = subprocess.run(command, capture_output=True, text=True, cwd=ROOT)
        if result.returncode != 0:
            sys.exit(f"{name}: splitray failed: {result.stderr.strip()}")
        runs[name] = json.loads(result.stdout)

    cpu = cpu_model()
    command = (f"bench/animate_compare.py --frames {args.frames} -t {args.threads}")
    lines = [f"CPU: {cpu}, {args.threads} threads; `{command}`; frames 1.. (frame 0 is the "
             "initial build); trace = 1024x768 primary pass + one shadow ray per hit.", "",
             "| sequence | frames | triangles | " +
             " | ".join(f"{s} update / trace / frame ms" for s in STRATEGIES) + " |",
             "|---|---:|---:|" + "---:|" * len(STRATEGIES)]
    for name, run in runs.items():
        cells = []
        for s in STRATEGIES:
            p = run["strategies"].get(s)
            cells.append("–" if p is None else
                         f"{p['median_update_ms']:.2f} / {p['median_trace_ms']:.1f} / "
                         f"{p['median_frame_ms']:.1f}")
        lines.append(f"| {name} | {run['frames']} | {run['triangles']} | " + " | ".join(cells) +
                     " |")
    out = pathlib.Path(args.out)
    write_atomic(out.with_suffix(".json"),
                 json.dumps({"cpu": cpu, "command": command, "runs": runs}, indent=1) + "\n")
    write_atomic(out.with_suffix(".md"), "\n".join(lines) + "\n")
    print("\n".join(lines))
    print(f"wrote {project_path(out.with_suffix('.json'))} and .md", file=sys.stderr)


if __name__ == "__main__":
    main()
