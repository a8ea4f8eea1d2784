#!/usr/bin/env python3
"""Sequence view of `make chart`: time per frame against per-frame error and against flicker, for an
animated scene with a reference sequence.

Usage (from anywhere; `pip install -r tools/chart_requirements.txt`, `cargo build --release` first):
    python3 tools/chart_sequence.py [--scene anim-ball] [--quick] [--frames A..B] [--out charts]
                                    [--bin target/release/pmrender] [--keep DIR]

The scene is scenes/NAME.toml (or tests/scenes/NAME.toml); its reference sequence is
tests/reference/NAME/frame-NNNN.exr with a sequence.json (tools/mitsuba_sequence.py), and every
sequence is rendered at the reference's size. Runs, each one `pmrender render` of the frames:
  pm (temporal cache)   pm with the defaults: one cache and its records carried from frame to frame;
                        then the same with --noise 0.02;
  pm (cache per frame)  pm with `[render.icache] temporal = false` (a temporary copy of the scene):
                        every frame an independent still; then the same with --noise 0.02;
  path                  several spp, chosen so that path's time per frame brackets pm's.
--quick renders frames 0..11 and fewer path spp values.
Each run is rendered --repeats times (default 3, --quick 1) and the fastest kept: the images are the
same every time, and other work on the machine only ever adds time. `--rerun 'path:256 spp,...'`
renders only the named runs (SERIES:RUN as in the table, or SERIES for all of its runs) and takes the
others from the --out folder's NAME-sequence.json of an earlier run with the same frames.

Per run: time per frame = the mean of the frames' `time_s` in pmrender's NAME-sequence.json (--stats;
each frame's time.total_s), the subprocess wall time divided by the frames next to it; per-frame relMSE
and temporal relMSE (flicker) against the reference as tools/flicker.py defines them (its functions):
    relMSE_t = mean (I_t - R_t)^2 / (R_t^2 + 0.01)
    temporal relMSE = mean over consecutive frames of mean ((I_t - I_s) - (R_t - R_s))^2 / (((R_t + R_s)/2)^2 + 0.01)

Writes into --out: NAME-sequence-error.png (per-frame relMSE against time per frame, log-log),
NAME-sequence-flicker.png (temporal relMSE against time per frame), NAME-sequence.md (the numbers, the
comparisons, the machine) and NAME-sequence.json; prints a one-line summary on stdout.
"""
import argparse
import hashlib
import json
import os
import re
import shutil
import subprocess
import sys
import tempfile
import time

import numpy as np

TOOLS = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(TOOLS)
sys.path.insert(0, TOOLS)
from chart import fmt, machine, scene_copy, scene_file  # noqa: E402
from flicker import flicker, frame_files  # noqa: E402
from mref_exr import read_rgb  # noqa: E402

PM_SERIES = ("pm (temporal cache)", "pm (cache per frame)")
QUICK_FRAMES = (0, 11)
PATH_SPP, PATH_SPP_QUICK = (4, 16, 64, 256), (16, 64, 256)
LOW_NOISE = 0.02


def reference_dir(name):
    return os.path.join(ROOT, "tests", "reference", name)


def has_sequence_reference(name):
    return os.path.isfile(os.path.join(reference_dir(name), "sequence.json")) and scene_file(name) is not None


def sequence_scenes():
    """Every scene with a reference sequence (tests/reference/NAME/sequence.json)."""
    base = os.path.join(ROOT, "tests", "reference")
    return sorted(n for n in os.listdir(base) if os.path.isdir(os.path.join(base, n)) and has_sequence_reference(n))


def plan(quick):
    """(series, label, method, spp, noise, edits) per run; edits are dotted [render] keys for a scene copy."""
    runs = []
    for series, edits in zip(PM_SERIES, ({}, {"icache.temporal": False})):
        runs.append((series, "defaults", "pm", None, None, edits))
        runs.append((series, f"noise {LOW_NOISE}", "pm", None, LOW_NOISE, edits))
    runs += [("path", f"{s} spp", "path", s, None, {}) for s in (PATH_SPP_QUICK if quick else PATH_SPP)]
    return runs


def sha256(path):
    h = hashlib.sha256()
    with open(path, "rb") as f:
        for chunk in iter(lambda: f.read(1 << 20), b""):
            h.update(chunk)
    return h.hexdigest()


def render_sequence(binary, scene, pattern, method, spp, noise, size, frames):
    """Renders frames A..B to `pattern` (one run of #); returns (wall s, rows of NAME-sequence.json)."""
    stats = pattern[:-4] + ".json"
    cmd = [binary, "render", scene, "-o", pattern, "--stats", stats, "--method", method,
           "--width", str(size[0]), "--height", str(size[1]), "--frames", f"{frames[0]}..{frames[1]}", "--quiet"]
    if spp is not None:
        cmd += ["--spp", str(spp)]
    if noise is not None:
        cmd += ["--noise", str(noise)]
    t0 = time.perf_counter()
    proc = subprocess.run(cmd, capture_output=True, text=True)
    wall = time.perf_counter() - t0
    if proc.returncode != 0:
        raise RuntimeError(f"{' '.join(cmd)}: exit {proc.returncode}: {proc.stderr.strip()[-400:]}")
    seq_json = re.sub(r"#+", "sequence", stats)
    with open(seq_json) as f:
        seq = json.load(f)
    if not seq.get("complete", True):
        raise RuntimeError(f"{seq_json}: the sequence is not complete")
    return wall, seq


def frame_times(seq, pattern):
    """Each frame's time: `time_s` of the sequence summary, else time.total_s of the frame's JSON."""
    out = {}
    for row in seq.get("frames", []):
        t = row.get("time_s")
        if t is None:
            digits = re.search(r"#+", pattern).group(0)
            path = pattern[:-4].replace(digits, str(row["frame"]).zfill(len(digits))) + ".json"
            with open(path) as f:
                t = json.load(f)["time"]["total_s"]
        out[row["frame"]] = float(t)
    return out


def run_scene(binary, name, quick, frames, repeats, tmp, log, keep_rows=None):
    """Renders and measures the plan's runs; a run found in keep_rows ({(series, label): row}) is taken
    from there instead."""
    scene = scene_file(name)
    ref_dir = reference_dir(name)
    with open(os.path.join(ref_dir, "sequence.json")) as f:
        ref_info = json.load(f)
    size = (ref_info["width"], ref_info["height"])
    ref_files = frame_files(os.path.join(ref_dir, "frame-####.exr"))
    if frames is None:
        frames = QUICK_FRAMES if quick else (min(ref_files), max(ref_files))
    missing = [f for f in range(frames[0], frames[1] + 1) if f not in ref_files]
    if missing:
        raise SystemExit(f"{name}: no reference for frames {missing[:5]}{'…' if len(missing) > 5 else ''}")
    ref_cache = {}

    def read(path):  # the reference frames are read once for all runs
        if path not in ref_cache:
            ref_cache[path] = read_rgb(path)
        return ref_cache[path]

    rows = []
    for i, (series, label, method, spp, noise, edits) in enumerate(plan(quick)):
        if keep_rows and (series, label) in keep_rows:
            rows.append(keep_rows[(series, label)])
            log(f"  {series:22s} {label:12s} (kept from the earlier run)")
            continue
        sc = scene_copy(scene, edits, tmp, f"{name}-seq-{i}") if edits else scene
        pattern = os.path.join(tmp, f"{name}-{i}", "f-####.exr")
        os.makedirs(os.path.dirname(pattern), exist_ok=True)
        # Renders are deterministic (the same images every repeat); repeats only steady the times.
        reps = []
        for _ in range(repeats):
            wall, seq = render_sequence(binary, sc, pattern, method, spp, noise, size, frames)
            reps.append((wall, frame_times(seq, pattern)))
        k = int(np.argmin([np.mean(list(t.values())) for _, t in reps]))  # the fastest repeat
        wall, times = reps[k]
        per_frame, pairs = flicker(frame_files(pattern), ref_files, lambda p: read_rgb(p) if p.startswith(tmp) else read(p))
        n = len(per_frame)
        row = {"series": series, "label": label, "method": method, "spp": spp, "noise": noise,
               "temporal": edits.get("icache.temporal", True) if method == "pm" else None,
               "frames": n, "frame_range": list(frames),
               "time_per_frame_s": float(np.mean(list(times.values()))),
               "first_frame_s": times.get(frames[0]),
               "wall_per_frame_s": wall / n,
               "repeats_time_per_frame_s": [float(np.mean(list(t.values()))) for _, t in reps],
               "relmse_mean": float(np.mean([r["relMSE"] for r in per_frame])),
               "relmse_max": float(np.max([r["relMSE"] for r in per_frame])),
               "temporal_relmse": float(np.mean([p["relMSE"] for p in pairs])) if pairs else float("nan"),
               "photon_traces": seq.get("photon_traces"),
               "records_reused_mean": (float(np.mean([r.get("records_reused", 0) for r in seq["frames"]]))
                                       if method == "pm" else None),
               "per_frame": [{"frame": r["frame"], "relMSE": r["relMSE"], "time_s": times.get(r["frame"])}
                             for r in per_frame],
               "pairs": [{"frames": p["frames"], "relMSE": p["relMSE"]} for p in pairs]}
        log(f"  {series:22s} {label:12s} {row['time_per_frame_s']:7.3f} s/frame  relMSE {row['relmse_mean']:.3g}  "
            f"flicker {row['temporal_relmse']:.3g}")
        rows.append(row)
    return rows, ref_info, size, frames


# ---- charts and table ---------------------------------------------------------------------------------

STYLES = {"pm (temporal cache)": ("o-", "C0"), "pm (cache per frame)": ("s--", "C1"), "path": ("D-", "C2")}


def label_at(series, label):
    """(offset in points, alignment) of a point's label: the temporal cache's to the left, the others' to the
    right; pm's defaults above, its other runs below, so that neighbouring pm points' labels do not collide."""
    if series not in PM_SERIES:
        return (5, 4), "left"
    dx, ha = (-6, "right") if series == PM_SERIES[0] else (6, "left")
    return (dx, 6 if label == "defaults" else -12), ha


def plot(rows, name, key, ylabel, title, path, floor=None):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(figsize=(7.5, 5))
    for series in dict.fromkeys(r["series"] for r in rows):
        pts = sorted((r["time_per_frame_s"], r[key], r["label"]) for r in rows
                     if r["series"] == series and np.isfinite(r[key]) and r[key] > 0)
        if not pts:
            continue
        style, color = STYLES.get(series, ("o-", None))
        ax.plot([p[0] for p in pts], [p[1] for p in pts], style, color=color, label=series, alpha=0.85)
        for x, y, label in pts:
            offset, ha = label_at(series, label)
            ax.annotate(label, (x, y), textcoords="offset points", xytext=offset, ha=ha, fontsize=7, color=color)
    if floor is not None and np.isfinite(floor) and floor > 0:
        ax.axhline(floor, color="k", ls=":", lw=1, label="reference's own noise")
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.margins(x=0.12)  # room for the outermost points' labels
    ax.set_xlabel("time per frame (s, pmrender's time_s)")
    ax.set_ylabel(ylabel)
    ax.set_title(title)
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def path_at(rows, t, key):
    """(path's `key` at time per frame t, extrapolated?): log-log interpolation between path's runs; past
    the slowest, ∝ 1/time (unbiased Monte Carlo); None below the fastest."""
    pts = sorted((r["time_per_frame_s"], r[key]) for r in rows if r["method"] == "path" and np.isfinite(r[key]))
    if not pts or t < pts[0][0]:
        return None, False
    if t > pts[-1][0]:
        return pts[-1][1] * pts[-1][0] / t, True
    lt, le = np.log([p[0] for p in pts]), np.log([p[1] for p in pts])
    return float(np.exp(np.interp(np.log(t), lt, le))), False


def find(rows, series, label):
    return next((r for r in rows if r["series"] == series and r["label"] == label), None)


def comparisons(rows):
    """Lines comparing the temporal cache with a cache per frame and with path at equal time."""
    out = []
    for label in ("defaults", f"noise {LOW_NOISE}"):
        t, s = find(rows, PM_SERIES[0], label), find(rows, PM_SERIES[1], label)
        if t and s:
            out.append(f"- pm {label}: the temporal cache takes **{s['time_per_frame_s'] / t['time_per_frame_s']:.2f}×** "
                       f"less time per frame than a cache per frame ({t['time_per_frame_s']:.3f} s against "
                       f"{s['time_per_frame_s']:.3f} s), its flicker is **{t['temporal_relmse'] / s['temporal_relmse']:.2f}×** "
                       f"theirs ({t['temporal_relmse']:.3g} against {s['temporal_relmse']:.3g}) and its per-frame relMSE "
                       f"{t['relmse_mean'] / s['relmse_mean']:.2f}× ({t['relmse_mean']:.3g} against {s['relmse_mean']:.3g}).")
    for r in rows:
        if r["method"] != "pm":
            continue
        pe, ex1 = path_at(rows, r["time_per_frame_s"], "relmse_mean")
        pf, ex2 = path_at(rows, r["time_per_frame_s"], "temporal_relmse")
        if pe is None:
            continue
        out.append(f"- {r['series']}, {r['label']}: path at the same time per frame ({r['time_per_frame_s']:.3f} s"
                   f"{', extrapolated as 1/t' if ex1 or ex2 else ''}) has relMSE {pe:.3g} ({pe / r['relmse_mean']:.1f}× pm's) "
                   f"and flicker {pf:.3g} ({pf / r['temporal_relmse']:.1f}× pm's).")
    return out


def write_markdown(path, name, rows, ref_info, size, frames, cmd, repeats, elapsed, warn, rerun_note=None):
    lines = [f"# {name}: sequence view", "",
             f"Machine: {machine()}. Generated by `{cmd}` in {elapsed / 60:.1f} min; frames {frames[0]}..{frames[1]} "
             f"at {size[0]}×{size[1]} (the reference's size), all threads; times are the fastest of {repeats} "
             f"render{'s' if repeats > 1 else ''} of the sequence per row (the images do not change between them)."
             f"{' ' + rerun_note if rerun_note else ''}", "",
             f"Reference: tests/reference/{name}/ ({ref_info.get('renderer', 'Mitsuba')}, {ref_info.get('integrator')}, "
             f"{ref_info.get('spp')} spp, own noise relMSE {fmt(ref_info.get('noise_relmse_mean'), '.2e')} per frame).", "",
             "relMSE = mean (I_t − R_t)² / (R_t² + 0.01) per frame, averaged over the frames; temporal relMSE (flicker) "
             "= mean over consecutive frames of mean ((I_t − I_s) − (R_t − R_s))² / (((R_t + R_s)/2)² + 0.01) "
             "(tools/flicker.py). Time per frame = the mean of pmrender's per-frame `time_s` (--stats); wall = the "
             "subprocess's wall time divided by the frames (includes loading the scene once).", ""]
    if warn:
        lines += [f"**Warning:** {warn}", ""]
    lines += [f"![error against time per frame]({name}-sequence-error.png) "
              f"![flicker against time per frame]({name}-sequence-flicker.png)", "",
              "| series | run | s/frame | wall s/frame | first frame s | relMSE mean | relMSE max | temporal relMSE | "
              "records reused/frame |",
              "|---|---|---:|---:|---:|---:|---:|---:|---:|"]
    for r in rows:
        reused = fmt(r["records_reused_mean"], ".0f") if r["records_reused_mean"] is not None else "—"
        lines.append(f"| {r['series']} | {r['label']} | {r['time_per_frame_s']:.3f} | {r['wall_per_frame_s']:.3f} | "
                     f"{fmt(r['first_frame_s'], '.3f')} | {r['relmse_mean']:.3g} | {r['relmse_max']:.3g} | "
                     f"{r['temporal_relmse']:.3g} | {reused} |")
    lines += ["", "Comparisons (path's numbers interpolated log–log between its runs at pm's time per frame):", ""]
    lines += comparisons(rows)
    lines.append("")
    with open(path, "w") as f:
        f.write("\n".join(lines))


def summary(name, rows, frames):
    t, s = find(rows, PM_SERIES[0], "defaults"), find(rows, PM_SERIES[1], "defaults")
    parts = [f"{name} frames {frames[0]}..{frames[1]}:"]
    if t:
        parts.append(f"pm temporal {t['time_per_frame_s']:.3f} s/frame relMSE {t['relmse_mean']:.3g} flicker {t['temporal_relmse']:.3g};")
    if s:
        parts.append(f"cache per frame {s['time_per_frame_s']:.3f} s/frame relMSE {s['relmse_mean']:.3g} flicker {s['temporal_relmse']:.3g};")
    if t and s:
        parts.append(f"temporal {s['time_per_frame_s'] / t['time_per_frame_s']:.2f}x faster, flicker "
                     f"{t['temporal_relmse'] / s['temporal_relmse']:.2f}x;")
        pf, _ = path_at(rows, t["time_per_frame_s"], "temporal_relmse")
        pe, _ = path_at(rows, t["time_per_frame_s"], "relmse_mean")
        if pe is not None:
            parts.append(f"path at equal time: relMSE {pe:.3g}, flicker {pf:.3g}")
    return " ".join(parts).rstrip(";")


def parse_frames(s):
    m = re.fullmatch(r"(\d+)\.\.(\d+)", s or "")
    if not m or int(m.group(1)) > int(m.group(2)):
        raise argparse.ArgumentTypeError(f"{s}: expected A..B with A <= B")
    return int(m.group(1)), int(m.group(2))


def parse_rerun(spec, quick):
    """{(series, label)} of the plan's runs named by 'SERIES:RUN,SERIES,...'."""
    runs = [(r[0], r[1]) for r in plan(quick)]
    chosen = set()
    for item in (x.strip() for x in spec.split(",") if x.strip()):
        series, _, label = item.partition(":")
        match = {r for r in runs if r[0] == series.strip() and (not label or r[1] == label.strip())}
        if not match:
            raise SystemExit(f"--rerun {item}: no such run; runs: {', '.join(f'{s}:{l}' for s, l in runs)}")
        chosen |= match
    return chosen


def run(binary, out, name="anim-ball", quick=False, frames=None, repeats=None, keep=None, log=None, rerun=None):
    """Renders, measures and writes the sequence view of one scene; returns the summary line."""
    log = log or (lambda s: print(s, file=sys.stderr, flush=True))
    if not has_sequence_reference(name):
        raise SystemExit(f"{name}: no scene with a reference sequence (tests/reference/{name}/sequence.json)")
    if not os.path.isfile(binary):
        raise SystemExit(f"{binary} not found: run `cargo build --release` first")
    os.makedirs(out, exist_ok=True)
    repeats = repeats or (1 if quick else 3)
    cmd = (f"python3 tools/chart_sequence.py --scene {name}{' --quick' if quick else ''}"
           f"{f' --frames {frames[0]}..{frames[1]}' if frames else ''}{f' --repeats {repeats}' if repeats != (1 if quick else 3) else ''}")
    t0, digest = time.perf_counter(), sha256(binary)
    keep_rows, rerun_note = None, None
    if rerun:
        chosen = parse_rerun(rerun, quick)
        with open(os.path.join(out, f"{name}-sequence.json")) as f:
            earlier = json.load(f)
        keep_rows = {(r["series"], r["label"]): r for r in earlier["runs"] if (r["series"], r["label"]) not in chosen}
        want = list(frames) if frames else (list(QUICK_FRAMES) if quick else None)
        if (want and earlier["frames"] != want) or earlier.get("binary_sha256") != digest:
            raise SystemExit(f"--rerun: {out}/{name}-sequence.json has other frames or another binary; render all runs")
        frames = tuple(earlier["frames"])
        cmd += f" --rerun '{rerun}'"
        rerun_note = (f"Rows {', '.join(f'{s} {l}' for s, l in sorted(chosen))} measured again "
                      f"{time.strftime('%Y-%m-%d %H:%M')} with the same binary, the others from the run before.")
    log(f"{name}: sequence view{' (quick)' if quick else ''}")
    with tempfile.TemporaryDirectory(prefix="pm-chart-seq-") as tmp:
        rows, ref_info, size, frames = run_scene(binary, name, quick, frames, repeats, tmp, log, keep_rows)
        if keep:
            shutil.copytree(tmp, keep, dirs_exist_ok=True)
    warn = None if sha256(binary) == digest else f"{binary} changed during the run: rows may come from two builds"
    if warn:
        log(f"warning: {warn}")
    elapsed = time.perf_counter() - t0
    floor = ref_info.get("noise_relmse_mean")
    plot(rows, name, "relmse_mean", "per-frame relMSE against the Mitsuba reference (mean over frames)",
         f"{name}: per-frame error against time per frame", os.path.join(out, f"{name}-sequence-error.png"), floor)
    plot(rows, name, "temporal_relmse", "temporal relMSE (flicker) against the reference",
         f"{name}: flicker against time per frame", os.path.join(out, f"{name}-sequence-flicker.png"))
    write_markdown(os.path.join(out, f"{name}-sequence.md"), name, rows, ref_info, size, frames, cmd, repeats, elapsed, warn,
                   rerun_note)
    with open(os.path.join(out, f"{name}-sequence.json"), "w") as f:
        json.dump({"scene": name, "frames": list(frames), "size": list(size), "machine": machine(),
                   "binary_sha256": digest, "warning": warn, "runs": rows}, f, indent=1)
    log(f"wrote {out}/{name}-sequence.md and charts in {elapsed:.0f} s")
    return summary(name, rows, frames)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--scene", default="anim-ball", help="a scene with tests/reference/NAME/sequence.json")
    ap.add_argument("--quick", action="store_true", help=f"frames {QUICK_FRAMES[0]}..{QUICK_FRAMES[1]}, fewer path runs")
    ap.add_argument("--frames", type=parse_frames, help="frames A..B (default: all the reference's; --quick: 0..11)")
    ap.add_argument("--out", default=os.path.join(ROOT, "charts"))
    ap.add_argument("--bin", default=os.path.join(ROOT, "target", "release", "pmrender"))
    ap.add_argument("--repeats", type=int, help="renders per run, the fastest kept (default 3; --quick: 1)")
    ap.add_argument("--rerun", help="render only these runs ('path:256 spp', 'path', ...), the others from the "
                    "earlier NAME-sequence.json in --out")
    ap.add_argument("--keep", help="copy the rendered frames and their statistics into this folder")
    args = ap.parse_args()
    print(run(args.bin, args.out, args.scene, args.quick, args.frames, args.repeats, args.keep, rerun=args.rerun))


if __name__ == "__main__":
    main()
