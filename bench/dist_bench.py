#!/usr/bin/python3
"""Rendering an animation across processes: `mpirun -np R splitray animate FRAMES --render DIR`
with R = 1, 2, 4 ranks of one thread each on this machine (ranks beyond its cores are
over-subscribed, and said so), against the single process (`splitray animate --render-only`,
one thread) in the same run. Reports frames per second, tile (frame) throughput per rank, the
measured compute, communication and assembly times, checks that every rank count writes the
single process's images byte for byte, and projects the scaling to 8-64 nodes from the
measured per-frame times (the model and its assumptions are written into the report).
Medians of --runs runs; JSON and Markdown into --out (default bench/results/dist.*).

    /usr/bin/python3 bench/dist_bench.py [--runs 3] [--frames 8] [-W 1024 -H 768]
"""

import argparse
import hashlib
import json
import os
import pathlib
import shutil
import statistics
import subprocess
import tempfile

from bench_common import ROOT, cpu_model, project_path

SEQUENCE = ROOT.parent / "shared" / "data" / "anim_horse_collapse" / "frames"




def run_animate(binary, ranks, args, out_dir, report):
    command = [binary, "animate", *args, "--render", str(out_dir), "--json-out", str(report)]
    if ranks == 0:  # the single process, no MPI
        command.insert(2, "--render-only")
    else:
        command = ["mpirun", "-np", str(ranks), "--oversubscribe", *command]
    env = dict(os.environ, OMPI_ALLOW_RUN_AS_ROOT="1", OMPI_ALLOW_RUN_AS_ROOT_CONFIRM="1")
    done = subprocess.run(command, env=env, capture_output=True, text=True)
    if done.returncode != 0:
        raise SystemExit(f"{' '.join(command)} failed:\n{done.stderr}")
    return json.loads(pathlib.Path(report).read_text())


def digests(folder):
    return {p.name: hashlib.sha256(p.read_bytes()).hexdigest() for p in sorted(folder.glob("*.png"))}


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--runs", type=int, default=3)
    parser.add_argument("--frames", type=int, default=8)
    parser.add_argument("-W", "--width", type=int, default=1024)
    parser.add_argument("-H", "--height", type=int, default=768)
    parser.add_argument("--binary", default=str(ROOT / "build" / "apps" / "splitray" / "splitray"))
    parser.add_argument("--out", default=str(ROOT / "bench" / "results" / "dist"))
    options = parser.parse_args()
    if not SEQUENCE.is_dir():
        raise SystemExit(f"{project_path(SEQUENCE)}: the shared sequence is missing")
    if shutil.which("mpirun") is None:
        raise SystemExit("mpirun: not found (scripts/install-deps.sh installs OpenMPI)")
    cores = os.cpu_count() or 1
    args = [str(SEQUENCE), "--frames", str(options.frames), "-W", str(options.width),
            "-H", str(options.height), "-t", "1", "--rays", "0"]
    rows, reference = [], None
    with tempfile.TemporaryDirectory() as work:
        work = pathlib.Path(work)
        for ranks in (0, 1, 2, 4):
            runs = []
            for r in range(options.runs):
                out = work / f"ranks{ranks}-{r}"
                report = run_animate(options.binary, ranks, args, out, work / f"{ranks}-{r}.json")
                images = digests(out)
                if reference is None:
                    reference = images
                runs.append((report, images == reference))
                shutil.rmtree(out)
            wall = statistics.median(rep["wall_ms"] for rep, _ in runs)
            report = min(runs, key=lambda run: abs(run[0]["wall_ms"] - wall))[0]
            frame_ms = [row["load_ms"] + row["build_ms"] + row["render_ms"]
                        for row in report.get("frame_rows", [])]
            stats = report.get("rank_stats", [])
            comm = max((s["comm_ms"] + s["assembly_ms"] for s in stats), default=0.0)
            rows.append({
                "ranks": ranks if ranks else "single process",
                "oversubscribed": ranks > cores,
                "wall_ms": wall,
                "frames_per_s": options.frames / (wall / 1000),
                "frame_compute_ms": statistics.median(frame_ms) if frame_ms else None,
                "comm_and_assembly_ms": comm,
                "comm_share": comm / wall if wall else None,
                "identical_images": all(same for _, same in runs),
            })
    single = rows[0]["wall_ms"]
    one = next(r for r in rows if r["ranks"] == 1)["wall_ms"]
    for row in rows:
        row["speedup_vs_single"] = single / row["wall_ms"]
        row["speedup_vs_one_rank"] = one / row["wall_ms"]
    # Projection: every frame is independent work of about the measured compute time; rank 0
    # hands out runs and writes every image. T(N) = frames * compute / N + frames * (comm +
    # write) per frame, with comm scaled from loopback to 10 Gbit/s for an image of W*H*3 bytes.
    one_rank = next(r for r in rows if r["ranks"] == 1)
    compute = one_rank["frame_compute_ms"] or one_rank["wall_ms"] / options.frames
    per_frame_comm = max(one_rank["comm_and_assembly_ms"] / options.frames,
                         options.width * options.height * 3 * 8 / 10e9 * 1000)
    frames = 1000
    projection = []
    for nodes in (8, 16, 32, 64):
        ranks = nodes * cores
        t = frames * compute / ranks + frames * per_frame_comm
        projection.append({"nodes": nodes, "ranks": ranks, "frames_per_s": frames / (t / 1000),
                           "speedup_vs_one_rank": frames * compute / t,
                           "efficiency": frames * compute / t / ranks})
    result = {
        "cpu": cpu_model(), "cores": cores, "sequence": project_path(SEQUENCE),
        "frames": options.frames, "width": options.width, "height": options.height,
        "runs": options.runs, "rows": rows, "projection": projection,
        "projection_model": (
            f"{frames} frames of the measured single-thread compute ({compute:.0f} ms) spread over "
            f"N nodes x {cores} ranks, plus a serial {per_frame_comm:.1f} ms per frame at rank 0 "
            "(the larger of the measured communication + assembly and an uncompressed RGB image "
            "over 10 Gbit/s); frames assumed independent (a run of predicted rebuilds per rank), "
            "loading from a shared file system not counted."),
    }
    out = pathlib.Path(options.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    out.with_suffix(".json").write_text(json.dumps(result, indent=2) + "\n")
    lines = [f"# splitray animate across ranks ({result['cpu']}, {cores} cores)", "",
             f"{options.frames} frames of {result['sequence']} at {options.width}x{options.height}, "
             f"one thread per rank, medians of {options.runs} runs.", "",
             "| ranks | frames/s | vs single process | vs 1 rank | comm + assembly | share | images identical |",
             "|---|---|---|---|---|---|---|"]
    for row in rows:
        name = f"{row['ranks']}" + (" (over-subscribed)" if row["oversubscribed"] else "")
        lines.append(f"| {name} | {row['frames_per_s']:.2f} | {row['speedup_vs_single']:.2f}x | "
                     f"{row['speedup_vs_one_rank']:.2f}x | "
                     f"{row['comm_and_assembly_ms']:.0f} ms | {100 * row['comm_share']:.1f}% | "
                     f"{'yes' if row['identical_images'] else 'NO'} |")
    lines += ["", "Projection: " + result["projection_model"], "",
              "| nodes | ranks | frames/s | speedup vs 1 rank | efficiency |", "|---|---|---|---|---|"]
    for p in projection:
        lines.append(f"| {p['nodes']} | {p['ranks']} | {p['frames_per_s']:.1f} | "
                     f"{p['speedup_vs_one_rank']:.1f}x | {100 * p['efficiency']:.0f}% |")
    out.with_suffix(".md").write_text("\n".join(lines) + "\n")
    print("\n".join(lines))


if __name__ == "__main__":
    main()
