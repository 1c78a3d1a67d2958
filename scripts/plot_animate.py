#!/usr/bin/python3
"""Plots of `splitray animate` CSV files (one per predictor): build time per frame of the
full rebuild, the predicted rebuild and the exact SAH builder, and - as in paper 000 Fig. 7 -
the actual and predicted root split positions over the frames.

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
    top.plot(frames, column(first, "build_ms_full"), label="full rebuild (golden)", color="black")
    top.plot(frames, column(first, "build_ms_sah"), label="exact sah", color="gray", linestyle=":")
    for rows in runs:
        name = rows[0]["predictor"]
        top.plot([int(r["frame"]) for r in rows], column(rows, "build_ms_predicted"), label=f"predicted ({name})")
    top.set_ylabel("build time per frame (ms)")
    top.legend(fontsize=8)
    top.set_title(args.title or "kd-tree rebuilds per frame")
    bottom.plot(frames, column(first, "root_actual"), label="actual root split", color="black")
    for rows in runs:
        name = rows[0]["predictor"]
        bottom.plot([int(r["frame"]) for r in rows], column(rows, "root_predicted"), linestyle="--",
                    marker=".", label=f"predicted ({name})")
    bottom.set_xlabel("frame")
    bottom.set_ylabel("root split position")
    bottom.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(args.out, dpi=110)


if __name__ == "__main__":
    main()
