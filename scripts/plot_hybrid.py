#!/usr/bin/python3
"""Bar charts of a `splitray bench hybrid` JSON report: as in paper 002 Fig. 6 the times of
the five passes (GPU passes from timer queries, the CPU ray pass from CPU timers) beside the
frame times of hybrid (interleaved, sequential) and Whitted; the CPU's rays against Whitted's;
and, as in Fig. 8/9, the pixels whose shadow state differs from ray-traced shadows with and
without boundary refinement.

usage: /usr/bin/python3 scripts/plot_hybrid.py --out FILE.png REPORT.json
"""
import argparse
import json

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

PASSES = [("shadow_map", "1 shadow map\n(GPU)"), ("id_and_mask", "2 ids + mask\n(GPU)"),
          ("blur", "3 blur\n(GPU)"), ("cpu_rays", "4 rays\n(CPU)"),
          ("composite", "5 composite\n(GPU)")]


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", required=True)
    parser.add_argument("report")
    args = parser.parse_args()
    with open(args.report) as f:
        r = json.load(f)

    fig, axes = plt.subplots(1, 3, figsize=(15, 4.8), gridspec_kw={"width_ratios": [3, 1.1, 1.1]})
    ax = axes[0]
    names = [label for _, label in PASSES] + ["hybrid\ninterleaved", "hybrid\nsequential", "whitted\n(CPU)"]
    values = [r["pass_ms"][key] for key, _ in PASSES] + [r["hybrid_ms"], r["sequential_ms"], r["whitted_ms"]]
    colors = ["#4c72b0", "#4c72b0", "#4c72b0", "#dd8452", "#4c72b0", "#55a868", "#8c8c8c", "#c44e52"]
    bars = ax.bar(range(len(values)), values, color=colors)
    for b, v in zip(bars, values):
        ax.annotate(f"{v:.1f}", (b.get_x() + b.get_width() / 2, b.get_height()), ha="center",
                    va="bottom", fontsize=8)
    ax.set_xticks(range(len(values)))
    ax.set_xticklabels(names, fontsize=8)
    ax.set_ylabel("ms")
    ax.set_title(f"pass and frame times, {r['triangles']:,} triangles, {r['width']}x{r['height']}, "
                 f"{100 * r['reflective_share']:.0f}% reflective pixels", fontsize=9)

    ax = axes[1]
    rays = [r["cpu_rays_hybrid"], r["cpu_rays_whitted"]]
    ax.bar([0, 1], rays, color=["#dd8452", "#c44e52"])
    ax.set_xticks([0, 1])
    ax.set_xticklabels(["hybrid\n(CPU pass)", "whitted"], fontsize=8)
    ax.set_title(f"CPU rays: hybrid = {100 * r['cpu_ray_share']:.1f}% of whitted", fontsize=9)
    for x, v in enumerate(rays):
        ax.annotate(f"{v:,}", (x, v), ha="center", va="bottom", fontsize=8)

    ax = axes[2]
    wrong = [r["shadow_wrong_unrefined"], r["shadow_wrong_refined"]]
    ax.bar([0, 1], wrong, color=["#8172b3", "#55a868"])
    ax.set_xticks([0, 1])
    ax.set_xticklabels(["shadow map\n(Fig. 8)", "refined, K=5\n(Fig. 9)"], fontsize=8)
    ax.set_title(f"wrong shadow pixels: {100 * r['shadow_wrong_fixed_share']:.1f}% removed", fontsize=9)
    for x, v in enumerate(wrong):
        ax.annotate(f"{v:,}", (x, v), ha="center", va="bottom", fontsize=8)

    fig.suptitle(f"splitray bench hybrid (paper 002 Fig. 6, 8/9) - GL: {r['gl_renderer']}, "
                 f"PSNR vs whitted {r['psnr_db']:.1f} dB", fontsize=10)
    fig.tight_layout()
    # (splitray runs this on a temporary name and renames the picture into place.)
    fig.savefig(args.out, dpi=110)


if __name__ == "__main__":
    main()
