#!/usr/bin/env python3
"""Speed against accuracy: renders each shipped scene that has a reference with every method at several
settings, measures wall time and error against the independent (Mitsuba) reference, and writes charts.

Usage (from anywhere; `pip install -r tools/chart_requirements.txt`, `cargo build --release` first):
    python3 tools/chart.py [--quick] [--scenes a,b] [--out charts] [--bin target/release/pmrender]

Scenes: scenes/NAME.toml or tests/scenes/NAME.toml (the large public scenes) with a reference
tests/reference/NAME-path.exr (+ .json); by default every shipped scene with a reference and Sibenik
and the glossy scenes of tests/scenes (`--scenes sponza` adds Sponza; with `--scenes`, the other scenes of
an earlier run into the same --out stay in its table); every render is made at the reference's size. Per scene it runs pmrender with
  pm      several spp at the defaults, then at the default spp: [render.icache] rays, photon counts,
          accuracy, visibility (a temporary copy of the scene with its [render] tables edited);
  pm-fg   a few spp;  path  several spp;  photons  two spp;
and measures the wall time (the subprocess) and `time.total_s` (pmrender's --stats), relMSE =
mean (x - r)^2 / (r^2 + 0.01) against the reference, HDR-FLIP (`flip-evaluator`, skipped when not
installed), and relMSE inside / outside two masks taken from one high-quality `pm` render (4x photons,
another seed): `caustic` where its caustic layer is > 10% of the pixel (and > 0.01), `specular` likewise for
its specular layer (caustics seen through glass or water land in that term). For the photon-map methods
the caustic and indirect layers are also compared with that render's (term noise, not bias).

Writes into --out: speed_accuracy_<scene>.png (relMSE against time, log-log, one curve per method, the
Pareto front marked), convergence_<scene>.png (`pmrender converge --method pm`: beauty against the
reference, caustic and indirect terms against the high-quality render's layers) and speed_accuracy.md (all
numbers, the equal-time comparison of pm and path, the machine).

Animated scenes with a reference sequence (tests/reference/NAME/sequence.json: anim-ball) get the sequence
view of tools/chart_sequence.py (time per frame against per-frame error and against flicker): by default
after the stills, or when --scenes names them; `--sequence` runs only the sequence view, `--no-sequence`
only the stills.
"""
import argparse
import json
import os
import platform
import subprocess
import sys
import tempfile
import time
import tomllib

import numpy as np

TOOLS = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(TOOLS)
sys.path.insert(0, TOOLS)
from mref_exr import read_rgb  # noqa: E402

RELMSE_EPS = 0.01  # the metric's denominator offset, as tools/compare.py
SEEDS = (0, 1, 2)  # renders averaged for the defaults and the gather-ray series
# Within noise of the Pareto front: no run is both this much faster and this much more accurate.
FRONT_TIME_TOL, FRONT_ERR_TOL = 0.03, 0.03
# pm's default spp (src/render/plan.rs): the most a pixel with Monte Carlo estimates takes; the others stop
# at aa_spp = min(32, spp). "pm spp=128" is pm with its defaults.
PM_DEFAULT_SPP = 128


def plan(quick, media=False, glossy=False):
    """(method, label, series, spp, edits) per run; edits are dotted [render] keys for the scene copy.
    Scenes with participating media add pm without the media records' gradients; scenes whose glossy
    lobes the radiance cache serves add pm without it and with fewer harmonic bands."""
    runs = [("pm", f"pm spp={s}", "pm (spp)", s, {}) for s in ((8, PM_DEFAULT_SPP) if quick else (4, 8, 16, 32, 64, PM_DEFAULT_SPP))]
    rays = (250,) if quick else (125, 250, 500, 1000)
    runs += [("pm", f"pm rays={r}", "pm (gather rays)", PM_DEFAULT_SPP, {"icache.rays": r}) for r in rays]
    photons = () if quick else (50_000, 800_000)
    runs += [("pm", f"pm photons={p}", "pm (photons)", PM_DEFAULT_SPP, {"photons.global": p, "photons.caustic": p // 2})
             for p in photons]
    if not quick:
        runs += [("pm", f"pm accuracy={a}", "pm (accuracy)", PM_DEFAULT_SPP, {"icache.accuracy": a}) for a in (0.25, 1.0)]
        runs += [("pm", "pm visibility", "pm (visibility)", PM_DEFAULT_SPP, {"icache.visibility": True})]
    runs += [("pm-fg", f"pm-fg spp={s}", "pm-fg", s, {}) for s in ((1,) if quick else (1, 2))]
    runs += [("path", f"path spp={s}", "path", s, {}) for s in ((16, 64, 256) if quick else (16, 64, 256, 1024))]
    runs += [("photons", f"photons spp={s}", "photons", s, {}) for s in ((8,) if quick else (8, 32))]
    if media:
        runs += [("pm", f"pm no media gradients spp={s}", "pm (no media gradients)", s,
                  {"icache.media_gradients": False}) for s in ((PM_DEFAULT_SPP,) if quick else (8, PM_DEFAULT_SPP))]
        runs += [("pm", "pm media visibility", "pm (media visibility)", PM_DEFAULT_SPP, {"icache.media_visibility": True})]
    if glossy:
        runs += [("pm", f"pm no radiance cache spp={s}", "pm (radiance cache off)", s,
                  {"icache.radiance_cache": False}) for s in ((PM_DEFAULT_SPP,) if quick else (8, PM_DEFAULT_SPP))]
        runs += [("pm", f"pm radiance bands={b}", "pm (radiance bands)", PM_DEFAULT_SPP,
                  {"icache.radiance_bands": b}) for b in ((6,) if quick else (4, 6, 8))]
    return runs


# ---- scene copies -------------------------------------------------------------------------------------

def toml_value(v):
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, (int, float)):
        return repr(v)
    if isinstance(v, str):
        return json.dumps(v)
    return "[" + ", ".join(toml_value(x) for x in v) + "]"


def toml_dump(d, prefix=""):
    """A TOML writer for pmrender's scene format: scalars and arrays, tables, arrays of tables."""
    out, subs = [], []
    for k, v in d.items():
        if isinstance(v, dict):
            subs.append((k, v))
        elif isinstance(v, list) and v and isinstance(v[0], dict):
            for item in v:
                subs.append((k, item, "aot"))
        else:
            out.append(f"{k} = {toml_value(v)}")
    for s in subs:
        name = f"{prefix}{s[0]}"
        out.append(f"\n[[{name}]]" if len(s) == 3 else f"\n[{name}]")
        out.append(toml_dump(s[1], name + "."))
    return "\n".join(out)


def scene_copy(scene_path, edits, tmp, tag):
    """Writes a copy of the scene with absolute file paths and the [render] edits applied; returns its path."""
    with open(scene_path, "rb") as f:
        d = tomllib.load(f)
    base = os.path.dirname(os.path.abspath(scene_path))
    for m in d.get("mesh", []):
        m["obj"] = os.path.join(base, m["obj"])
    for m in d.get("materials", {}).values():
        if "texture" in m:
            m["texture"] = os.path.join(base, m["texture"])
    for key, value in edits.items():
        table = d.setdefault("render", {})
        *path, last = key.split(".")
        for p in path:
            table = table.setdefault(p, {})
        table[last] = value
    out = os.path.join(tmp, f"{tag}.toml")
    with open(out, "w") as f:
        f.write(toml_dump(d) + "\n")
    return out


# ---- rendering and measuring --------------------------------------------------------------------------

def render(binary, scene, out_exr, method, spp, size, seed=None):
    stats = out_exr[:-4] + ".json"
    cmd = [binary, "render", scene, "-o", out_exr, "--stats", stats, "--method", method, "--spp", str(spp),
           "--width", str(size[0]), "--height", str(size[1]), "--quiet"]
    if seed is not None:
        cmd += ["--seed", str(seed)]
    t0 = time.perf_counter()
    proc = subprocess.run(cmd, capture_output=True, text=True)
    wall = time.perf_counter() - t0
    if proc.returncode != 0:
        raise RuntimeError(f"{' '.join(cmd)}: exit {proc.returncode}: {proc.stderr.strip()[-400:]}")
    with open(stats) as f:
        j = json.load(f)
    return wall, j.get("time", {}).get("total_s", float("nan")), j


def rel_mse_map(a, r):
    return (a.astype(np.float64) - r) ** 2 / (r.astype(np.float64) ** 2 + RELMSE_EPS)


def masked(err, mask):
    return float(err[mask].mean()) if mask.any() else float("nan")


def flip_error(a, r):
    try:
        import flip_evaluator
    except ImportError:
        return float("nan")
    _, mean, _ = flip_evaluator.evaluate(np.maximum(r, 0).astype(np.float32), np.maximum(a, 0).astype(np.float32), "HDR")
    return float(mean)


def layer_or_none(path, name):
    try:
        return read_rgb(path, name)
    except (KeyError, ValueError, OSError, RuntimeError):
        return None


def term_mask(hq_path, name, beauty):
    t = layer_or_none(hq_path, name)
    if t is None:
        return np.zeros(beauty.shape[:2], bool)
    lt, lb = t.mean(axis=2), beauty.mean(axis=2)
    return (lt > 0.1 * lb) & (lt > 0.01)


def measure(exr, ref, masks, hq_path):
    a = read_rgb(exr)
    err = rel_mse_map(a, ref).mean(axis=2)
    row = {"relmse": float(err.mean()), "flip": flip_error(a, ref)}
    for name, m in masks.items():
        row[f"in_{name}"], row[f"out_{name}"] = masked(err, m), masked(err, ~m)
    for term in ("caustic", "indirect"):
        x, y = layer_or_none(exr, term), layer_or_none(hq_path, term)
        row[f"term_{term}"] = float(rel_mse_map(x, y).mean()) if x is not None and y is not None and y.any() else float("nan")
    return row


def scene_file(name):
    for folder in (("scenes",), ("tests", "scenes")):
        path = os.path.join(ROOT, *folder, f"{name}.toml")
        if os.path.isfile(path):
            return path
    return None


def run_scene(binary, name, quick, tmp, log):
    scene = scene_file(name)
    ref_path = os.path.join(ROOT, "tests", "reference", f"{name}-path.exr")
    ref = read_rgb(ref_path).astype(np.float64)
    size = (ref.shape[1], ref.shape[0])
    hq_scale = 4
    hq_edits = {"photons.global": 200_000 * hq_scale, "photons.caustic": 100_000 * hq_scale}
    hq_path = os.path.join(tmp, f"{name}-hq.exr")
    log(f"{name}: high-quality pm render for masks and term references")
    _, _, hq_stats = render(binary, scene_copy(scene, hq_edits, tmp, f"{name}-hq"), hq_path, "pm",
                            16 if quick else 64, size, seed=7)
    # The radiance cache's series only where it has records (lobes wide enough for it).
    glossy = hq_stats.get("glossy", {}).get("records", 0) > 0
    masks = {k: term_mask(hq_path, k, read_rgb(hq_path)) for k in ("caustic", "specular")}
    rows = []
    with open(scene) as f:
        media = "[[medium]]" in f.read()
    for i, (method, label, series, spp, edits) in enumerate(plan(quick, media, glossy)):
        sc = scene_copy(scene, edits, tmp, f"{name}-{i}") if edits else scene
        # The defaults and the gather-ray series are the means of SEEDS renders: the defaults choose their
        # rays, and whether that choice is on the Pareto front is a comparison within a few per cent.
        seeds = SEEDS if (series == "pm (gather rays)" or label == f"pm spp={PM_DEFAULT_SPP}") and not quick else (0,)
        runs = []
        for seed in seeds:
            exr = os.path.join(tmp, f"{name}-{i}-{seed}.exr")
            wall, total, stats = render(binary, sc, exr, method, spp, size, seed=seed if len(seeds) > 1 else None)
            runs.append({"wall_s": wall, "total_s": total, **measure(exr, ref, masks, hq_path)})
        means = {k: float(np.mean([r[k] for r in runs])) for k in runs[0]}
        row = {"scene": name, "method": method, "label": label + (f" ({len(seeds)} seeds)" if len(seeds) > 1 else ""),
               "series": series, "spp": spp, "seeds": len(seeds),
               "rays_chosen": stats.get("gather", {}).get("rays_chosen"), **means}
        log(f"  {label:22s} {wall:7.2f} s  relMSE {row['relmse']:.5f}  FLIP {row['flip']:.4f}")
        rows.append(row)
    conv = convergence(binary, scene, name, ref_path, hq_path, quick, tmp)
    mask_px = {k: int(m.sum()) for k, m in masks.items()}
    return rows, conv, mask_px


def convergence(binary, scene, name, ref_path, hq_path, quick, tmp):
    """`pmrender converge --method pm` against a reference whose beauty is Mitsuba's and whose caustic and
    indirect layers are the high-quality render's."""
    import mitsuba as mi
    if mi.variant() is None:
        mi.set_variant("scalar_rgb")
    chans, names = [read_rgb(ref_path)], ["R", "G", "B"]
    for term in ("caustic", "indirect"):
        t = layer_or_none(hq_path, term)
        if t is not None:
            chans.append(t)
            names += [f"{term}.R", f"{term}.G", f"{term}.B"]
    arr = np.ascontiguousarray(np.concatenate(chans, axis=2), dtype=np.float32)
    composite = os.path.join(tmp, f"{name}-composite.exr")
    mi.Bitmap(arr, mi.Bitmap.PixelFormat.MultiChannel, names).write(composite)
    counts = "1e4,1e5" if quick else "1e4,3e4,1e5,3e5,6e5"
    out_dir = os.path.join(tmp, f"{name}-converge")
    cmd = [binary, "converge", scene, "--photons", counts, "--reference", composite, "-o", out_dir,
           "--method", "pm", "--spp", "8", "--quiet"]
    proc = subprocess.run(cmd, capture_output=True, text=True)
    if proc.returncode != 0:
        raise RuntimeError(f"{' '.join(cmd)}: exit {proc.returncode}: {proc.stderr.strip()[-400:]}")
    with open(os.path.join(out_dir, "converge.json")) as f:
        return json.load(f)


# ---- charts and table ---------------------------------------------------------------------------------

def pareto(rows):
    front, best = [], float("inf")
    for r in sorted(rows, key=lambda r: (r["wall_s"], r["relmse"])):
        if r["relmse"] < best:
            front.append(r)
            best = r["relmse"]
    return front


def front_verdict(d, rows, front):
    """Whether run `d` is on the Pareto front, within noise of it (no run both FRONT_TIME_TOL faster and
    FRONT_ERR_TOL more accurate), or not (and what beats it)."""
    if id(d) in front:
        return "yes"
    better = [r for r in rows if r is not d and r["wall_s"] < (1 - FRONT_TIME_TOL) * d["wall_s"]
              and r["relmse"] < (1 - FRONT_ERR_TOL) * d["relmse"]]
    if not better:
        return (f"within noise (no run is {FRONT_TIME_TOL:.0%} faster and {FRONT_ERR_TOL:.0%} more accurate)")
    return "no: " + ", ".join(f"{r['label']} {r['relmse']:.5f} in {r['wall_s']:.2f} s" for r in better)


def plot_speed(rows, name, path):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(figsize=(7.5, 5))
    styles = {"pm (spp)": "o-", "pm (gather rays)": "s--", "pm (photons)": "^--", "pm (accuracy)": "v--",
              "pm-fg": "D-", "path": "o-", "photons": "x-"}
    for series in dict.fromkeys(r["series"] for r in rows):
        pts = sorted((r["wall_s"], r["relmse"]) for r in rows if r["series"] == series)
        ax.plot(*zip(*pts), styles.get(series, "o-"), label=series, alpha=0.85)
    front = pareto(rows)
    ax.step([r["wall_s"] for r in front], [r["relmse"] for r in front], "k:", where="post", lw=1)
    ax.scatter([r["wall_s"] for r in front], [r["relmse"] for r in front], s=140, facecolors="none",
               edgecolors="k", label="Pareto front", zorder=5)
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("wall time (s)")
    ax.set_ylabel("relMSE against the Mitsuba reference")
    ax.set_title(f"{name}: error against time")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def plot_convergence(conv, name, path):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(figsize=(6.5, 4.5))
    for key, label in (("beauty", "beauty vs reference"), ("caustic", "caustic term"), ("indirect", "indirect term")):
        pts = [(c["photons"], c[key]) for c in conv if c.get(key) is not None and np.isfinite(c[key]) and c[key] > 0]
        if pts:
            ax.plot(*zip(*pts), "o-", label=label)
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("photons (global and caustic map targets)")
    ax.set_ylabel("relMSE")
    ax.set_title(f"{name}: pm (8 spp) against photon count")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def path_error_at(rows, t):
    """(relMSE of path at time t, extrapolated?): log-log interpolation between path's runs; beyond the
    slowest, relMSE ∝ 1/time (unbiased Monte Carlo); None below the fastest."""
    pts = sorted((r["wall_s"], r["relmse"]) for r in rows if r["method"] == "path")
    if not pts or t < pts[0][0]:
        return None, False
    if t > pts[-1][0]:
        return pts[-1][1] * pts[-1][0] / t, True
    lt, le = np.log([p[0] for p in pts]), np.log([p[1] for p in pts])
    return float(np.exp(np.interp(np.log(t), lt, le))), False


def fmt(x, spec=".5f"):
    return "—" if x is None or not np.isfinite(x) else format(x, spec)


def machine():
    cpu = "unknown"
    try:
        with open("/proc/cpuinfo") as f:
            cpu = next((l.split(":", 1)[1].strip() for l in f if l.startswith("model name")), cpu)
    except OSError:
        pass
    return f"{os.cpu_count()} logical CPUs (nproc), {cpu}, {platform.system()} {platform.release()}"


def default_bound(name):
    return 0.006 if "water" in name else 0.003  # water caustics get twice the bound


def write_markdown(path, results, quick, elapsed, charted=None):
    """`charted`: the scenes this run rendered, when the others were kept from an earlier run."""
    run = (f"Generated by `python3 tools/chart.py{' --quick' if quick else ''}` in {elapsed / 60:.1f} min"
           if charted is None else
           f"{', '.join(charted)} charted again by `python3 tools/chart.py --scenes …` in "
           f"{elapsed / 60:.1f} min, the other scenes kept from an earlier run (same machine)")
    lines = ["# Speed against accuracy", "",
             f"Machine: {machine()}. {run}; renders at the reference's size with all threads.", "",
             "relMSE = mean (x − r)² / (r² + 0.01) against the Mitsuba 3 path-traced reference "
             "(tests/reference/NAME-path.exr). FLIP: HDR-FLIP mean (flip-evaluator). `in/out caustic`, "
             "`in/out specular`: relMSE inside / outside the mask where a high-quality pm render's caustic / "
             "specular layer is > 10% of the pixel. `caustic term`, `indirect term`: the layer's relMSE against "
             "that render's layer (noise of the term, not its bias). Wall = subprocess time; pmrender = "
             "`time.total_s` of --stats.", ""]
    for name, (rows, conv, mask_px, ref_info) in results.items():
        lines += [f"## {name}", "",
                  f"Reference: {ref_info.get('width')}×{ref_info.get('height')}, {ref_info.get('spp')} spp, "
                  f"noise relMSE {fmt(ref_info.get('noise_relmse'), '.2e')}. Mask pixels: caustic "
                  f"{mask_px['caustic']}, specular {mask_px['specular']}.", "",
                  f"![speed against accuracy](speed_accuracy_{name}.png) ![convergence](convergence_{name}.png)", "",
                  "| run | wall s | pmrender s | relMSE | FLIP | in caustic | out caustic | in specular | "
                  "out specular | caustic term | indirect term |",
                  "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|"]
        front = {id(r) for r in pareto(rows)}
        for r in rows:
            star = " ★" if id(r) in front else ""
            lines.append(f"| {r['label']}{star} | {r['wall_s']:.2f} | {fmt(r['total_s'], '.2f')} | {fmt(r['relmse'])} | "
                         f"{fmt(r['flip'], '.4f')} | {fmt(r['in_caustic'])} | {fmt(r['out_caustic'])} | "
                         f"{fmt(r['in_specular'])} | {fmt(r['out_specular'])} | {fmt(r['term_caustic'])} | "
                         f"{fmt(r['term_indirect'])} |")
        lines += ["", "★ = on the Pareto front (no run is both faster and more accurate).", ""]
        d = next((r for r in rows if r["label"].startswith(f"pm spp={PM_DEFAULT_SPP}")), None)
        if d:
            bound = default_bound(name)
            chosen = f", {d['rays_chosen']} gather rays chosen from pass A's noise" if d.get("rays_chosen") else ""
            lines.append(f"**Defaults** (pm, at most {PM_DEFAULT_SPP} spp, 32 without Monte Carlo estimates{chosen}): relMSE {fmt(d['relmse'])} — "
                         f"{'meets' if d['relmse'] <= bound else 'MISSES'} the bound {bound}; on the Pareto front: "
                         f"**{front_verdict(d, rows, front)}**.")
        lines += ["", "Equal time, pm against path: the best pm run within the budget; path's relMSE interpolated log–log "
                  "between its runs, or extrapolated as 1/time past the slowest (marked 1/t):", "",
                  "| budget s | best pm run | pm relMSE | path relMSE | path / pm |", "|---:|---|---:|---:|---:|"]
        pm_rows = [r for r in rows if r["method"] == "pm"]
        wins = []
        for t in sorted(r["wall_s"] for r in pm_rows if r["wall_s"] >= 1.0):
            best = min((r for r in pm_rows if r["wall_s"] <= t), key=lambda r: r["relmse"])
            pe, extrapolated = path_error_at(rows, t)
            wins.append(pe is not None and best["relmse"] < pe)
            lines.append(f"| {t:.2f} | {best['label']} | {fmt(best['relmse'])} | {fmt(pe)}{' (1/t)' if extrapolated else ''} | "
                         f"{fmt(pe / best['relmse'] if pe else None, '.2f')} |")
        lines.append(f"\npm beats path at every measured budget ≥ 1 s: **{'yes' if wins and all(wins) else 'no'}**.")
        lines += ["", "Photon-count convergence (`pmrender converge --method pm --spp 8`; terms against the "
                  "high-quality render's layers):", "", "| photons | time s | beauty | caustic | indirect |",
                  "|---:|---:|---:|---:|---:|"]
        for c in conv:
            lines.append(f"| {c['photons']} | {c['time_s']:.2f} | {fmt(c['beauty'])} | {fmt(c['caustic'])} | "
                         f"{fmt(c['indirect'])} |")
        lines.append("")
    with open(path, "w") as f:
        f.write("\n".join(lines))


# Large public scenes and the glossy scenes charted by default (the large ones take several minutes each).
LARGE_DEFAULT = ("sibenik", "cornell-glossy", "cornell-glossy-floor", "sibenik-polished", "sponza-blender",
                 "sponza-conference")


def has_reference(name):
    return os.path.isfile(os.path.join(ROOT, "tests", "reference", f"{name}-path.exr"))


def shipped_scenes():
    names = sorted(f[:-5] for f in os.listdir(os.path.join(ROOT, "scenes")) if f.endswith(".toml"))
    return [n for n in names if has_reference(n)]


def chartable(name):
    return scene_file(name) is not None and has_reference(name)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--quick", action="store_true", help="fewer runs (a few minutes)")
    ap.add_argument("--scenes", help="comma-separated scene names (default: every scene with a reference)")
    ap.add_argument("--out", default=os.path.join(ROOT, "charts"))
    ap.add_argument("--bin", default=os.path.join(ROOT, "target", "release", "pmrender"))
    seq_opt = ap.add_mutually_exclusive_group()
    seq_opt.add_argument("--sequence", action="store_true", help="only the sequence view of the animated scenes")
    seq_opt.add_argument("--no-sequence", action="store_true", help="only the stills (no sequence view)")
    args = ap.parse_args()
    if not os.path.isfile(args.bin):
        raise SystemExit(f"{args.bin} not found: run `cargo build --release` first")
    import chart_sequence
    if args.scenes:
        asked = args.scenes.split(",")
        sequences = [n for n in asked if chart_sequence.has_sequence_reference(n) and not chartable(n)]
        names = [n for n in asked if n not in sequences]
    else:
        sequences = chart_sequence.sequence_scenes()
        names = shipped_scenes() + [n for n in LARGE_DEFAULT if chartable(n)]
    if args.sequence:
        names = []
    if args.no_sequence:
        sequences = []
    missing = [n for n in names if not chartable(n)]
    if missing:
        raise SystemExit(f"no scene with a reference: {', '.join(missing)}")
    os.makedirs(args.out, exist_ok=True)
    log = lambda s: print(s, file=sys.stderr, flush=True)  # noqa: E731
    if names:
        stills(args, names, log)
    for name in sequences:
        print(chart_sequence.run(args.bin, args.out, name, args.quick, log=log))


def reference_info(name):
    with open(os.path.join(ROOT, "tests", "reference", f"{name}-path.json")) as f:
        return json.load(f)


def kept_results(out, names):
    """With --scenes: the other scenes' results of an earlier run into the same --out (so that the
    table stays whole when a few scenes are charted again), those that still have a reference."""
    path = os.path.join(out, "speed_accuracy.json")
    if not os.path.isfile(path):
        return {}
    with open(path) as f:
        old = json.load(f)
    return {n: (r["runs"], r["converge"], r["mask_pixels"], reference_info(n))
            for n, r in old.items() if n not in names and has_reference(n)}


def stills(args, names, log):
    t0 = time.perf_counter()
    results = kept_results(args.out, names) if args.scenes else {}
    with tempfile.TemporaryDirectory(prefix="pm-chart-") as tmp:
        for name in names:
            rows, conv, mask_px = run_scene(args.bin, name, args.quick, tmp, log)
            results[name] = (rows, conv, mask_px, reference_info(name))
            plot_speed(rows, name, os.path.join(args.out, f"speed_accuracy_{name}.png"))
            plot_convergence(conv, name, os.path.join(args.out, f"convergence_{name}.png"))
    kept = len(results) > len(names)
    write_markdown(os.path.join(args.out, "speed_accuracy.md"), results, args.quick, time.perf_counter() - t0,
                   names if kept else None)
    with open(os.path.join(args.out, "speed_accuracy.json"), "w") as f:
        json.dump({n: {"runs": r[0], "converge": r[1], "mask_pixels": r[2]} for n, r in results.items()}, f, indent=1)
    log(f"wrote {args.out}/speed_accuracy.md and charts in {time.perf_counter() - t0:.0f} s")


if __name__ == "__main__":
    main()
