#!/usr/bin/env python3
"""A longer wait, a better image: `pm --time` against `path --time` at budgets from the default time to
100 times it, relMSE against each scene's independent (Mitsuba) reference, with the fitted slope of each
series and the targets as ratios.

Usage (from anywhere; `pip install -r tools/chart_requirements.txt -r tools/requirements.txt`,
`cargo build --release` first):
    python3 tools/progressive_chart.py [--scenes cornell-caustics,sibenik] [--multiples 1,2,4,8,25,100]
                                       [--out charts] [--bin target/release/pmrender]

Per scene (scenes/NAME.toml or tests/scenes/NAME.toml, at its reference's size,
tests/reference/NAME-path.exr): the default time t0 is the wall time of `pm` at its defaults (the mean
of two renders after one that warms the caches); then for each multiple m, `pm --time m·t0` and `path --time m·t0`, each measured by its
wall time and relMSE = mean (x − r)² / (r² + 0.01). Writes progressive_NAME.png (relMSE against wall
time, log–log, each series' least-squares slope in the legend, the reference's own noise dashed) and
progressive.md (every number, the targets: pm at most 0.35× path's relMSE up to 25× t0 and never above
it up to 100×; pm's error falling at least 4× from 1× to 25×; its slope over the last decade at most
−0.5), and progressive.json.
"""
import argparse
import json
import os
import platform
import subprocess
import sys
import tempfile
import time

import numpy as np

TOOLS = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(TOOLS)
sys.path.insert(0, TOOLS)
from mref_exr import read_rgb  # noqa: E402

RELMSE_EPS = 0.01  # the metric's denominator offset, as tools/compare.py
DEFAULT_SCENES = ("cornell-caustics", "interior-diffuse", "sibenik")
DEFAULT_MULTIPLES = (1, 2, 4, 8, 25, 100)


def scene_file(name):
    for folder in (("scenes",), ("tests", "scenes")):
        path = os.path.join(ROOT, *folder, f"{name}.toml")
        if os.path.isfile(path):
            return path
    raise SystemExit(f"no scene {name} in scenes/ or tests/scenes/")


def render(binary, scene, out, size, method, extra=()):
    stats = out[:-4] + ".json"
    cmd = [binary, "render", scene, "-o", out, "--stats", stats, "--method", method, "--width", str(size[0]),
           "--height", str(size[1]), "--quiet", *extra]
    t0 = time.perf_counter()
    proc = subprocess.run(cmd, capture_output=True, text=True)
    wall = time.perf_counter() - t0
    if proc.returncode != 0:
        raise RuntimeError(f"{' '.join(cmd)}: exit {proc.returncode}: {proc.stderr.strip()[-400:]}")
    with open(stats) as f:
        return wall, json.load(f)


def rel_mse(path, ref):
    a = read_rgb(path).astype(np.float64)
    return float(((a - ref) ** 2 / (ref ** 2 + RELMSE_EPS)).mean())


def slope(points):
    """Least-squares slope of log relMSE against log time."""
    if len(points) < 2:
        return float("nan")
    x, y = np.log([p[0] for p in points]), np.log([p[1] for p in points])
    return float(np.polyfit(x, y, 1)[0])


def run_scene(binary, name, multiples, tmp, log):
    scene = scene_file(name)
    ref_path = os.path.join(ROOT, "tests", "reference", f"{name}-path.exr")
    ref = read_rgb(ref_path).astype(np.float64)
    size = (ref.shape[1], ref.shape[0])
    with open(ref_path[:-4] + ".json") as f:
        ref_noise = json.load(f).get("noise_relmse")
    # A first render warms the page cache (the binary, the meshes) and is not counted.
    render(binary, scene, os.path.join(tmp, f"{name}-warm.exr"), size, "pm")
    walls = []
    for seed in (0, 1):
        wall, _ = render(binary, scene, os.path.join(tmp, f"{name}-d{seed}.exr"), size, "pm",
                         ("--seed", str(seed)))
        walls.append(wall)
    t0 = float(np.mean(walls))
    default_err = float(np.mean([rel_mse(os.path.join(tmp, f"{name}-d{s}.exr"), ref) for s in (0, 1)]))
    log(f"{name}: pm defaults {t0:.2f} s, relMSE {default_err:.5f}")
    rows = []
    for m in multiples:
        budget = m * t0
        for method in ("pm", "path"):
            out = os.path.join(tmp, f"{name}-{method}-{m}.exr")
            wall, stats = render(binary, scene, out, size, method, ("--time", f"{budget:.3f}"))
            row = {"scene": name, "method": method, "multiple": m, "budget_s": budget, "wall_s": wall,
                   "passes": stats.get("progressive", {}).get("passes"), "relmse": rel_mse(out, ref)}
            log(f"  {method:4s} {m:4g}x {budget:8.2f} s budget: {wall:8.2f} s, {row['passes']} passes, "
                f"relMSE {row['relmse']:.6f}")
            rows.append(row)
    return {"scene": name, "size": size, "default_s": t0, "default_relmse": default_err,
            "reference_noise": ref_noise, "rows": rows}


def corrected(result, r):
    """A row's relMSE with the reference's own noise taken off (it is in every measurement), at least
    a tenth of that noise."""
    noise = result.get("reference_noise") or 0.0
    return max(r["relmse"] - noise, 0.1 * noise) if noise else r["relmse"]


def verdicts(result):
    """The targets for one scene, each as (what, measured, met), on relMSE less the reference's noise."""
    by = {(r["method"], r["multiple"]): {**r, "relmse": corrected(result, r)} for r in result["rows"]}
    ms = sorted({r["multiple"] for r in result["rows"]})
    out = []
    ratios = [(m, by[("pm", m)]["relmse"] / by[("path", m)]["relmse"]) for m in ms]
    upto25 = [q for m, q in ratios if m <= 25]
    if upto25:
        out.append(("pm / path relMSE, worst up to 25x (target <= 0.35)", max(upto25), max(upto25) <= 0.35))
    if ms[-1] >= 100:
        out.append(("pm / path relMSE, worst up to 100x (target <= 1)", max(q for _, q in ratios),
                    max(q for _, q in ratios) <= 1.0))
    if 1 in ms and 25 in ms:
        fall = by[("pm", 1)]["relmse"] / by[("pm", 25)]["relmse"]
        out.append(("pm's error fall from 1x to 25x (target >= 4)", fall, fall >= 4.0))
    last = [m for m in ms if m >= ms[-1] / 10]
    if len(last) >= 2:
        s = slope([(by[("pm", m)]["wall_s"], by[("pm", m)]["relmse"]) for m in last])
        out.append((f"pm's slope over {last[0]}x-{last[-1]}x (target <= -0.5)", s, s <= -0.5))
    return out


def plot(result, path):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(figsize=(7, 4.8))
    for method, style in (("pm", "o-"), ("path", "s--")):
        pts = sorted((r["wall_s"], r["relmse"]) for r in result["rows"] if r["method"] == method)
        ax.plot(*zip(*pts), style, label=f"{method} --time (slope {slope(pts):.2f})")
    if result["reference_noise"]:
        ax.axhline(result["reference_noise"], color="grey", ls=":", label="reference's own noise")
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("wall time (s)")
    ax.set_ylabel("relMSE against the Mitsuba reference")
    ax.set_title(f"{result['scene']}: a time budget, pm against path")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def table(results):
    lines = ["# A time budget: pm against path", "",
             "relMSE = mean (x − r)² / (r² + 0.01) against the scene's Mitsuba reference, its own noise "
             "included; budgets are multiples of `pm`'s default wall time on this machine.", "",
             "| scene | multiple | budget (s) | pm wall (s) | pm passes | pm relMSE | path wall (s) | path relMSE "
             "| pm / path |", "|---|---:|---:|---:|---:|---:|---:|---:|---:|"]
    for res in results:
        by = {(r["method"], r["multiple"]): r for r in res["rows"]}
        for m in sorted({r["multiple"] for r in res["rows"]}):
            p, q = by[("pm", m)], by[("path", m)]
            lines.append(f"| {res['scene']} | {m:g}× | {p['budget_s']:.2f} | {p['wall_s']:.2f} | {p['passes']} | "
                         f"{p['relmse']:.6f} | {q['wall_s']:.2f} | {q['relmse']:.6f} | {p['relmse'] / q['relmse']:.3f} |")
    lines += ["", "The targets, on relMSE less the reference's own noise (`noise_relmse` of its JSON):", "",
              "| scene | target | measured | met |", "|---|---|---:|---|"]
    for res in results:
        for what, value, met in verdicts(res):
            lines.append(f"| {res['scene']} | {what} | {value:.3f} | {'yes' if met else 'no'} |")
    lines += ["", f"Machine: {platform.processor() or platform.machine()}, {os.cpu_count()} cores, "
              f"{time.strftime('%Y-%m-%d')}."]
    return "\n".join(lines) + "\n"


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--scenes", default=",".join(DEFAULT_SCENES))
    ap.add_argument("--multiples", default=",".join(str(m) for m in DEFAULT_MULTIPLES))
    ap.add_argument("--out", default=os.path.join(ROOT, "charts"))
    ap.add_argument("--bin", default=os.path.join(ROOT, "target", "release", "pmrender"))
    ap.add_argument("--from-json", nargs="+", help="tabulate and chart earlier runs' progressive.json")
    a = ap.parse_args()
    if a.from_json:
        results = [res for path in a.from_json for res in json.load(open(path))]
        os.makedirs(a.out, exist_ok=True)
        for res in results:
            plot(res, os.path.join(a.out, f"progressive_{res['scene']}.png"))
        with open(os.path.join(a.out, "progressive.md"), "w") as f:
            f.write(table(results))
        with open(os.path.join(a.out, "progressive.json"), "w") as f:
            json.dump(results, f, indent=1)
        print(table(results))
        return
    multiples = [float(m) if "." in m else int(m) for m in a.multiples.split(",")]
    os.makedirs(a.out, exist_ok=True)
    results = []
    with tempfile.TemporaryDirectory() as tmp:
        for name in a.scenes.split(","):
            res = run_scene(a.bin, name, multiples, tmp, lambda s: print(s, flush=True))
            plot(res, os.path.join(a.out, f"progressive_{name}.png"))
            results.append(res)
    with open(os.path.join(a.out, "progressive.md"), "w") as f:
        f.write(table(results))
    with open(os.path.join(a.out, "progressive.json"), "w") as f:
        json.dump(results, f, indent=1)
    print(table(results))
    if not all(met for res in results for _, _, met in verdicts(res)):
        print("some targets are not met (see the table)", file=sys.stderr)


if __name__ == "__main__":
    main()
