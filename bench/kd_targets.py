#!/usr/bin/python3
"""Issue #20's from-scratch kd targets over several `splitray bench build-trace` JSON reports.

Each ratio is taken within one report (the same run, the same rays as Embree), then the median
over the reports, per mesh: binned build x Embree medium, golden / binned SAH cost x sah's,
primary and diffuse rays of the batched kd call x `rtcIntersect1`. Prints a Markdown table.

    /usr/bin/python3 bench/kd_targets.py RUN1.json RUN2.json RUN3.json
"""

import json
import statistics
import sys

BUILDERS = ("sah", "golden", "binned")


def ratios(mesh):
    res = {(r["accel"], r["builder"]): r for r in mesh["results"] if "error" not in r}
    kd = [res[("kd", b)] for b in BUILDERS]
    embree = res[("embree", "medium")]
    trace = lambda k, kind: k["trace"][kind]["batched"]["ratio_to_embree_single"]
    return {
        "build_ms": [k["build_ms"] for k in kd],
        "binned_build": kd[2]["build_ms"] / embree["build_ms"],
        "cost": [kd[1]["sah_cost"] / kd[0]["sah_cost"], kd[2]["sah_cost"] / kd[0]["sah_cost"]],
        "constants": (kd[0]["sah_kt"], kd[0]["sah_ki"]),
        "primary": [trace(k, "primary") for k in kd],
        "diffuse": [trace(k, "diffuse") for k in kd],
    }


def median_of(values):
    if isinstance(values[0], list):
        return [statistics.median(v) for v in zip(*values)]
    return statistics.median(values)


def main(paths):
    reports = [json.load(open(p)) for p in paths]
    first = reports[0]["machine"]
    print(f"{len(reports)} runs of `splitray bench build-trace`, {first['cpu']}, "
          f"{first['threads']} threads, from {first['date_utc']}; medians over the runs.\n")
    print("| mesh | triangles | kd sah / golden / binned ms | binned × Embree medium build (≤ 3) "
          "| golden / binned SAH × sah's (≤ 1.05) | primary × `rtcIntersect1` sah / golden / "
          "binned (≥ 1.0) | diffuse × `rtcIntersect1` sah / golden / binned |")
    print("|---|--:|--:|--:|--:|--:|--:|")
    summary = {"binned_build": [], "cost": [], "primary": [], "diffuse": []}
    constants = set()
    for i, mesh in enumerate(reports[0]["meshes"]):
        runs = [ratios(r["meshes"][i]) for r in reports]
        m = {key: median_of([r[key] for r in runs]) for key in runs[0] if key != "constants"}
        constants.update(r["constants"] for r in runs)
        for key in summary:
            summary[key].append(m[key])
        three = lambda v, f="{:.2f}": " / ".join(f.format(x) for x in v)
        print(f"| {mesh['name']} | {mesh['triangles']:,} | {three(m['build_ms'], '{:.1f}')} | "
              f"{m['binned_build']:.2f}× | {three(m['cost'], '{:.3f}')} | {three(m['primary'])} | "
              f"{three(m['diffuse'])} |")
    n = len(summary["binned_build"])
    b = summary["binned_build"]
    print(f"\nkd constants (K_T, K_I): {sorted(constants)}")
    print(f"binned build ≤ 3× Embree medium: {sum(x <= 3 for x in b)} of {n} "
          f"({min(b):.2f}-{max(b):.2f}×)")
    for j, name in enumerate(("golden", "binned")):
        c = [x[j] for x in summary["cost"]]
        print(f"{name} SAH ≤ 1.05× sah's: {sum(x <= 1.05 for x in c)} of {n} "
              f"({min(c):.3f}-{max(c):.3f}×)")
    for j, name in enumerate(BUILDERS):
        p = [x[j] for x in summary["primary"]]
        d = [x[j] for x in summary["diffuse"]]
        print(f"{name}: primary ≥ 1.0× on {sum(x >= 1 for x in p)} of {n} ({min(p):.2f}-"
              f"{max(p):.2f}×), diffuse {min(d):.2f}-{max(d):.2f}×")


if __name__ == "__main__":
    if len(sys.argv) < 2:
        sys.exit("usage: kd_targets.py REPORT.json [REPORT.json ...]")
    main(sys.argv[1:])
