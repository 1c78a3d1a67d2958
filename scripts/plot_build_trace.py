#!/usr/bin/python3
"""Bar charts of a `splitray bench build-trace` JSON report: per mesh, every structure's build
time and its primary and diffuse Mrays/s as ratios to Embree medium measured in the same run
(build: lower is better; throughput: against Embree's rtcIntersect1, higher is better), with the
targets of issue 20 (which replaced issue 3's) drawn as lines: kd binned build at most 3x
Embree medium's, kd primary rays at least 1.0x; diffuse rays are reported without a target.

usage: /usr/bin/python3 scripts/plot_build_trace.py --out FILE.png REPORT.json
"""
import argparse
import json

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

# (accel, builder, call whose throughput is drawn, label, colour)
SERIES = [
    ("kd", "sah", "batched", "kd sah", "#9ecae1"),
    ("kd", "golden", "batched", "kd golden", "#3182bd"),
    ("kd", "binned", "batched", "kd binned", "#08519c"),
    ("bih", "global", "single", "BIH global", "#a1d99b"),
    ("bvh", "binned", "single", "BVH binned", "#fdae6b"),
    ("bvh", "sbvh", "single", "BVH sbvh", "#e6550d"),
    ("embree", "low", "single", "Embree low", "#bdbdbd"),
    ("embree", "high", "single", "Embree high", "#636363"),
]


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", required=True)
    parser.add_argument("report")
    args = parser.parse_args()
    with open(args.report) as f:
        report = json.load(f)
    meshes = report["meshes"]
    names = [m["name"] for m in meshes]
    present = [s for s in SERIES
               if any((r["accel"], r["builder"]) == s[:2] for m in meshes for r in m["results"])]

    def ratios(metric):
        out = {s: [] for s in present}
        for m in meshes:
            by = {(r["accel"], r["builder"]): r for r in m["results"]}
            ref = by.get(("embree", "medium"))
            for s in present:
                r = by.get(s[:2])
                if r is None or ref is None:
                    out[s].append(float("nan"))
                elif metric == "build":
                    out[s].append(r["build_ms"] / max(ref["build_ms"], 1e-9))
                else:
                    mine = r["trace"][metric][s[2]]["mrays_per_s"]
                    out[s].append(mine / ref["trace"][metric]["single"]["mrays_per_s"])
        return out

    panels = [("build", "build time / Embree medium (log)", True, [(3.0, "kd binned target 3x")]),
              ("primary", "primary Mrays/s / Embree rtcIntersect1", False, [(1.0, "target 1.0x")]),
              ("diffuse", "diffuse Mrays/s / Embree rtcIntersect1", False, [])]
    fig, axes = plt.subplots(3, 1, figsize=(max(10, 0.9 * len(names) + 3), 11), sharex=True)
    width = 0.8 / max(len(present), 1)
    for ax, (metric, title, log, lines) in zip(axes, panels):
        values = ratios(metric)
        for k, s in enumerate(present):
            xs = [i - 0.4 + width * (k + 0.5) for i in range(len(names))]
            ax.bar(xs, values[s], width, label=s[3], color=s[4])
        for y, label in lines:
            ax.axhline(y, color="black", linestyle="--", linewidth=0.8)
            ax.annotate(label, (len(names) - 0.5, y), ha="right", va="bottom", fontsize=8)
        ax.axhline(1.0, color="black", linewidth=0.5)
        if log:
            ax.set_yscale("log")
        ax.set_ylabel(title, fontsize=9)
        ax.grid(axis="y", alpha=0.3)
    axes[0].legend(ncol=4, fontsize=8, loc="upper left")
    axes[-1].set_xticks(range(len(names)))
    axes[-1].set_xticklabels(names, rotation=30, ha="right")
    machine = report.get("machine", {})
    settings = report.get("settings", {})
    def sah_label(settings):
        # The constants given for every structure, else each structure's default.
        kt, ki = settings.get("traversal_cost"), settings.get("intersection_cost")
        defaults = settings.get("sah_defaults")
        if kt is None and ki is None and defaults:
            return (f"K_T/K_I: kd {defaults['kd'][0]:g}/{defaults['kd'][1]:g}, "
                    f"others {defaults['others'][0]:g}/{defaults['others'][1]:g}")
        return f"K_T = {kt}, K_I = {ki}"
    fig.suptitle(f"splitray bench build-trace: {machine.get('cpu', '')}, "
                 f"{machine.get('threads', '')} threads, {machine.get('date_utc', '')}, "
                 f"{sah_label(settings)}",
                 fontsize=10)
    fig.tight_layout()
    fig.savefig(args.out, dpi=100)


if __name__ == "__main__":
    main()
