#!/usr/bin/python3
"""Plots of `splitray animate` CSV files (one per predictor): build time per frame of the
full rebuild, the predicted rebuild and the exact SAH builder, and - as in paper 000 Fig. 7 -
the actual and predicted root split positions over the frames. Columns a run does not have
(Embree's updates: no kd builds, no splits) are left empty in the CSV and out of the plot.

usage: /usr/bin/python3 scripts/plot_animate.py --out FILE.png A.csv [B.csv ...]
"""
import argparse
import csv

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402


def read(path):
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


def column(rows, key):
    return [float(r[key]) if r[key] != "" else float("nan") for r in rows]


def plot(axes, x, y, **style):
    if any(v == v for v in y):  # not all NaN
        axes.plot(x, y, **style)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", required=True)
    parser.add_argument("--title", default="")
    parser.add_argument("csv", nargs="+")
    args = parser.parse_args()
    runs = [read(p) for p in args.csv]
    fig, (top, bottom) = plt.subplots(2, 1, figsize=(9, 7), sharex=True)
    first = runs[0]
    frames = [int(r["frame"]) for r in first]
    plot(top, frames, column(first, "build_ms_full"), label="full rebuild (golden)", color="black")
    plot(top, frames, column(first, "build_ms_sah"), label="exact sah", color="gray", linestyle=":")
    for rows in runs:
        name = rows[0]["predictor"]
        label = name if name.startswith("embree") else f"predicted ({name})"
        plot(top, [int(r["frame"]) for r in rows], column(rows, "build_ms_predicted"), label=label)
    top.set_ylabel("build time per frame (ms)")
    top.legend(fontsize=8)
    top.set_title(args.title or "kd-tree rebuilds per frame")
    plot(bottom, frames, column(first, "root_actual"), label="actual root split", color="black")
    for rows in runs:
        name = rows[0]["predictor"]
        plot(bottom, [int(r["frame"]) for r in rows], column(rows, "root_predicted"), linestyle="--",
             marker=".", label=f"predicted ({name})")
    if not bottom.lines:  # no splits (Embree): the primary-ray trace time per frame instead
        for rows in runs:
            plot(bottom, [int(r["frame"]) for r in rows], column(rows, "trace_ms_predicted"),
                 label=f"trace ({rows[0]['predictor']})")
        bottom.set_ylabel("primary-ray trace per frame (ms)")
    else:
        bottom.set_ylabel("root split position")
    bottom.set_xlabel("frame")
    bottom.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(args.out, dpi=110)


if __name__ == "__main__":
    main()
