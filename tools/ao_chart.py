#!/usr/bin/env python3
"""What the cache buys for ambient occlusion: `ao` (through the irradiance cache) against `ao-direct` (a
gather at every camera sample) at equal time.

Usage (from anywhere; `pip install -r tools/chart_requirements.txt`, `cargo build --release` first):
    python3 tools/ao_chart.py [--scenes sibenik,cornell-caustics] [--size N] [--ref-spp 32]
                              [--out charts] [--bin target/release/pmrender]

Scenes: scenes/NAME.toml or tests/scenes/NAME.toml. Per scene, at N² pixels, it runs pmrender with
  ao         at its defaults, with the most samples a pixel takes (--spp) 4, 8, 16 and 128 (the
             default; the noise target 0.04 stops most pixels earlier, aa_spp every one at 32);
  ao-direct  at 1, 2, 4, 8 and 16 spp with no noise target (every pixel takes them all);
and measures each render's time (`time.total_s` of pmrender's --stats: the render, not the scene's
loading, which is the same for both) and relMSE = mean (x - r)^2 / (r^2 + 0.01) against a reference:
the independent one of tools/mref_ao.py (Mitsuba's ray casting) in tests/reference/NAME-ao.exr when
there is one and --size is not given (N is then its size; its noise is the `noise_relmse` of its
JSON), else `ao-direct` at --ref-spp samples, no noise target, another seed (its noise the relMSE of
two such renders halved). The reference's noise is drawn and tabled as `reference noise`.

Writes into --out: ao_<scene>.png (relMSE against time, log-log, one curve per method) and ao.md (every
run, and per scene the equal-time comparison: `ao-direct`'s relMSE at `ao`'s default time, interpolated
log-log between its runs, and the time `ao-direct` takes to reach `ao`'s default error, extrapolated
along the slope of its last two runs where its runs do not reach it). Each render is one subprocess; run
the tool alone on the machine (`flock` it with other timings).
"""
import argparse
import json
import math
import os
import platform
import subprocess
import sys
import tempfile

import numpy as np

TOOLS = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(TOOLS)
sys.path.insert(0, TOOLS)
from mref_exr import read_rgb  # noqa: E402

RELMSE_EPS = 0.01  # the metric's denominator offset, as tools/compare.py
# 128: ao's default (src/render/plan.rs). Past 32 (aa_spp's default) every pixel stops at the noise
# target or at 32, so 64 would repeat 128's image.
AO_SPP = (4, 8, 16, 128)
DIRECT_SPP = (1, 2, 4, 8, 16)
REF_SEED = 1000


def scene_path(name):
    for d in ("scenes", "tests/scenes"):
        p = os.path.join(ROOT, d, name + ".toml")
        if os.path.exists(p):
            return p
    raise SystemExit(f"no scene {name} in scenes/ or tests/scenes/")


def render(binary, scene, method, spp, noise, seed, size, tmp):
    """(image, render seconds) of one run."""
    stem = os.path.join(tmp, f"{method}-{spp}-{noise}-{seed}")
    cmd = [binary, "render", scene, "-o", stem + ".exr", "--stats", stem + ".json", "--method", method,
           "--spp", str(spp), "--seed", str(seed), "--width", str(size), "--height", str(size), "--quiet"]
    if noise is not None:
        cmd += ["--noise", str(noise)]
    proc = subprocess.run(cmd, capture_output=True, text=True)
    if proc.returncode != 0:
        raise SystemExit(f"{' '.join(cmd)} failed:\n{proc.stderr}")
    with open(stem + ".json") as f:
        seconds = json.load(f)["time"]["total_s"]
    return read_rgb(stem + ".exr")[:, :, 0].astype(np.float64), seconds


def rel_mse(a, r):
    return float(np.mean((a - r) ** 2 / (r ** 2 + RELMSE_EPS)))


def loglog_at(xs, ys, x):
    """y at x on the log-log polyline through (xs, ys) (sorted by xs), extended along its end segments."""
    lx, ly = np.log(xs), np.log(ys)
    i = int(np.clip(np.searchsorted(lx, math.log(x)) - 1, 0, len(lx) - 2))
    t = (math.log(x) - lx[i]) / (lx[i + 1] - lx[i])
    return float(math.exp(ly[i] + t * (ly[i + 1] - ly[i])))


def reference(binary, name, scene, size, ref_spp, tmp):
    """(image, its noise relMSE, what it is, size)."""
    stored = os.path.join(ROOT, "tests", "reference", f"{name}-ao.exr")
    if size is None and os.path.exists(stored):
        with open(os.path.splitext(stored)[0] + ".json") as f:
            info = json.load(f)
        img = read_rgb(stored)[:, :, 0].astype(np.float64)
        return img, info["noise_relmse"], f"tests/reference/{name}-ao.exr ({info['renderer']})", img.shape[1]
    size = size or 128
    print(f"{name}: reference (ao-direct, {ref_spp} spp)", file=sys.stderr)
    ref, _ = render(binary, scene, "ao-direct", ref_spp, 0, REF_SEED, size, tmp)
    other, _ = render(binary, scene, "ao-direct", ref_spp, 0, REF_SEED + 1, size, tmp)
    return ref, rel_mse(other, ref) / 2.0, f"ao-direct at {ref_spp} spp", size


def run_scene(binary, name, size, ref_spp, tmp):
    scene = scene_path(name)
    ref, ref_noise, ref_what, size = reference(binary, name, scene, size, ref_spp, tmp)
    runs = []
    for method, spps, noise in (("ao", AO_SPP, None), ("ao-direct", DIRECT_SPP, 0)):
        for spp in spps:
            img, seconds = render(binary, scene, method, spp, noise, 0, size, tmp)
            runs.append({"method": method, "spp": spp, "time_s": seconds, "relmse": rel_mse(img, ref),
                         "mean_ratio": float(img.mean() / ref.mean())})
            print(f"  {method} {spp} spp: {seconds:.2f} s, relMSE {runs[-1]['relmse']:.3g}", file=sys.stderr)
    ao = next(r for r in runs if r["method"] == "ao" and r["spp"] == AO_SPP[-1])
    direct = sorted((r for r in runs if r["method"] == "ao-direct"), key=lambda r: r["time_s"])
    dt, de = [r["time_s"] for r in direct], [r["relmse"] for r in direct]
    # Time against error, by the error falling along ao-direct's runs (sorted by error, descending).
    by_err = sorted(direct, key=lambda r: r["relmse"])
    t_equal_err = loglog_at([r["relmse"] for r in by_err], [r["time_s"] for r in by_err], ao["relmse"])
    return {
        "scene": name, "size": size, "reference": ref_what,
        "reference_noise_relmse": ref_noise, "runs": runs,
        "ao_default": ao,
        "direct_relmse_at_ao_time": loglog_at(dt, de, ao["time_s"]),
        "direct_time_at_ao_error": t_equal_err,
        "time_ratio": t_equal_err / ao["time_s"],
    }


def chart(result, path):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(figsize=(6, 4.2))
    for method, style in (("ao", "o-"), ("ao-direct", "s-")):
        rs = sorted((r for r in result["runs"] if r["method"] == method), key=lambda r: r["spp"])
        ax.plot([r["time_s"] for r in rs], [r["relmse"] for r in rs], style, label=method)
        for r in rs:
            ax.annotate(f"{r['spp']}", (r["time_s"], r["relmse"]), textcoords="offset points", xytext=(4, 4),
                        fontsize=7)
    ax.axhline(result["reference_noise_relmse"], ls="--", color="grey", lw=0.8, label="reference noise")
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("render time (s)")
    ax.set_ylabel("relMSE against the reference")
    ax.set_title(f"{result['scene']} {result['size']}²: ao (cache) vs ao-direct; labels: spp", fontsize=10)
    ax.grid(True, which="both", lw=0.3)
    ax.legend()
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def table(results):
    lines = [f"Machine: {platform.processor() or platform.machine()}, {os.cpu_count()} threads. "
             "Time: pmrender's `time.total_s` (the render, without loading the scene). References: "
             + "; ".join(f"{r['scene']}: {r['reference']}" for r in results) + ".", ""]
    lines += ["| scene | size | ao (defaults) time | ao relMSE | ao-direct relMSE at that time | ao-direct time to "
              "ao's relMSE | ratio | reference noise |", "|---|---|---|---|---|---|---|---|"]
    for r in results:
        a = r["ao_default"]
        lines.append(f"| {r['scene']} | {r['size']}² | {a['time_s']:.2f} s | {a['relmse']:.2e} | "
                     f"{r['direct_relmse_at_ao_time']:.2e} | {r['direct_time_at_ao_error']:.1f} s | "
                     f"{r['time_ratio']:.1f}× | {r['reference_noise_relmse']:.1e} |")
    lines += ["", "| scene | method | spp | time (s) | relMSE | mean / reference |", "|---|---|---|---|---|---|"]
    for r in results:
        for run in r["runs"]:
            lines.append(f"| {r['scene']} | {run['method']} | {run['spp']} | {run['time_s']:.2f} | "
                         f"{run['relmse']:.2e} | {run['mean_ratio']:.4f} |")
    return "\n".join(lines) + "\n"


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--scenes", default="sibenik,cornell-caustics")
    ap.add_argument("--size", type=int, help="image width and height (default: the stored reference's, else 128)")
    ap.add_argument("--ref-spp", type=int, default=32, help="an ao-direct reference's spp (default 32)")
    ap.add_argument("--out", default=os.path.join(ROOT, "charts"))
    ap.add_argument("--bin", default=os.path.join(ROOT, "target", "release", "pmrender"))
    args = ap.parse_args()
    if (args.size is not None and args.size < 8) or args.ref_spp < 1:
        raise SystemExit("--size must be at least 8 and --ref-spp at least 1")
    if not os.path.exists(args.bin):
        raise SystemExit(f"{args.bin}: no such binary (cargo build --release, or --bin)")
    os.makedirs(args.out, exist_ok=True)
    results = []
    with tempfile.TemporaryDirectory(prefix="ao-chart-") as tmp:
        for name in args.scenes.split(","):
            results.append(run_scene(args.bin, name, args.size, args.ref_spp, tmp))
            chart(results[-1], os.path.join(args.out, f"ao_{name}.png"))
    with open(os.path.join(args.out, "ao.json"), "w") as f:
        json.dump(results, f, indent=2)
    with open(os.path.join(args.out, "ao.md"), "w") as f:
        f.write(table(results))
    print(table(results))


if __name__ == "__main__":
    main()
