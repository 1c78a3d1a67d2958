#!/usr/bin/python3
"""Training curve of `splitray train` (NAME.loss.csv): the total loss and its tree-cost and
bound-penalty terms against the epoch (epoch 0: the untrained network), with the mean cost
relative to a greedy top on a second axis.

usage: /usr/bin/python3 scripts/plot_loss.py --out FILE.png NAME.loss.csv
"""
import argparse
import csv

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", required=True)
    parser.add_argument("csv")
    args = parser.parse_args()
    with open(args.csv, newline="") as f:
        rows = list(csv.DictReader(f))
    epochs = [int(r["epoch"]) for r in rows]

    def col(key):
        return [float(r[key]) for r in rows]

    fig, ax = plt.subplots(figsize=(8, 5))
    ax.plot(epochs, col("loss"), marker="o", label="total loss (Eq. 8 + bound penalty)")
    ax.plot(epochs, col("tree_loss"), marker="s", label="tree cost term")
    ax.plot(epochs, col("bound_loss"), marker="^", label="bound penalty (Huber, Eq. 9-10)")
    ax.set_xlabel("epoch (0 = before training)")
    ax.set_ylabel("loss")
    ax.set_xticks(epochs)
    ax.grid(True, alpha=0.3)
    cost = ax.twinx()
    cost.plot(epochs, col("mean_relative_cost"), color="gray", linestyle=":", marker=".",
              label="mean cost / greedy top's")
    cost.set_ylabel("cost relative to the greedy top")
    lines = ax.get_lines() + cost.get_lines()
    ax.legend(lines, [line.get_label() for line in lines], fontsize=8, loc="upper right")
    ax.set_title("splitray train: loss per epoch")
    fig.tight_layout()
    fig.savefig(args.out, dpi=100)


if __name__ == "__main__":
    main()
