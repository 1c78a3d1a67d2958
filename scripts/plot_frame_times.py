#!/usr/bin/python3
"""Plot of `splitray animate --compare` (its CSV): per frame, the update time (top) and the
trace time of the frame pass (bottom) of every strategy, log scale, one line each.

usage: /usr/bin/python3 scripts/plot_frame_times.py --out FILE.png COMPARE.csv
"""
import argparse
import csv
from collections import defaultdict

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", required=True)
    parser.add_argument("--title", default="")
    parser.add_argument("csv")
    args = parser.parse_args()
    series = defaultdict(lambda: ([], [], []))
    with open(args.csv, newline="") as f:
        for row in csv.DictReader(f):
            frames, update, trace = series[row["strategy"]]
            frames.append(int(row["frame"]))
            update.append(float(row["update_ms"]))
            trace.append(float(row["trace_ms"]))
    if not series:
        raise SystemExit(f"{args.csv}: no rows")
    fig, (top, bottom) = plt.subplots(2, 1, figsize=(9, 7), sharex=True)
    for name, (frames, update, trace) in series.items():
        top.plot(frames, update, label=name, linewidth=1.2)
        bottom.plot(frames, trace, label=name, linewidth=1.2)
    top.set_yscale("log")
    bottom.set_yscale("log")
    top.set_ylabel("update ms (build, refit or rebuild)")
    bottom.set_ylabel("trace ms (primary + shadow rays)")
    bottom.set_xlabel("frame")
    top.legend(fontsize=8, ncol=2)
    top.grid(True, which="both", alpha=0.3)
    bottom.grid(True, which="both", alpha=0.3)
    top.set_title(args.title or "Frame time per strategy")
    fig.tight_layout()
    fig.savefig(args.out, dpi=110)


if __name__ == "__main__":
    main()
