#!/usr/bin/env python3
"""Flicker of a rendered sequence against a reference sequence: per-frame relMSE and temporal relMSE.

Usage:
    python3 tools/flicker.py SEQUENCE REFERENCE [--json]

SEQUENCE and REFERENCE each name a sequence of EXRs: a pattern with one run of # for the frame number
(out/ball-####.exr, as pmrender writes it), a glob (quote it: 'out/ball-*.exr'), or a folder (its
*.exr). Frames are matched by the number in their file name (the last run of digits); only frames
present in both are compared, in order. Reads beauty R,G,B with tools/mref_exr.read_rgb.

Definitions (tools/compare.py's convention: per pixel and channel, denominator r^2 + 0.01):
    per-frame   relMSE_t  = mean over pixels and channels of (I_t - R_t)^2 / (R_t^2 + 0.01)
    flicker     relMSE_dt = mean over pixels and channels of
                            ((I_t - I_s) - (R_t - R_s))^2 / (((R_t + R_s) / 2)^2 + 0.01)
                where s is the frame before t in the compared set (normally t - 1)
    temporal relMSE       = mean of relMSE_dt over the consecutive pairs
The difference images are compared against the reference's difference, but normalised by the
reference's brightness at that pixel (the mean of the two frames), not by the difference itself: a
static region has R_t - R_s = 0, and relMSE(d_I, d_R) taken literally would divide by 0 + 0.01 there,
an absolute error that changes with the scene's exposure. Normalised by the brightness, a frame that
changes by 1 % of its value where the reference does not change gives 1e-4, whatever the exposure —
the visible size of a pop. A still sequence rendered identically every frame has a temporal relMSE equal
to that of the reference's own frame-to-frame noise (zero for a noiseless reference).

The reference's own noise is part of both numbers. When REFERENCE has a sequence.json written by
tools/mitsuba_sequence.py, its per-frame noise_relmse is reported next to the per-frame relMSE.

Exits 2 on an unreadable file, a size mismatch or no common frames.
"""
import argparse
import glob
import json
import os
import re
import sys

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

EPS = 0.01


def rel_mse(a, r):
    """tools/compare.py's relMSE: mean over pixels and channels of (a - r)^2 / (r^2 + 0.01)."""
    a, r = np.asarray(a, dtype=np.float64), np.asarray(r, dtype=np.float64)
    if a.shape != r.shape:
        raise ValueError(f"size mismatch: {a.shape} vs {r.shape}")
    if not np.all(np.isfinite(a)):
        return float("inf")
    return float(np.mean((a - r) ** 2 / (r ** 2 + EPS)))


def rel_mse_diff(i_t, i_s, r_t, r_s):
    """Flicker of one pair of frames: the sequence's change against the reference's, relative to the
    reference's brightness (see the module header)."""
    i_t, i_s, r_t, r_s = (np.asarray(x, dtype=np.float64) for x in (i_t, i_s, r_t, r_s))
    if not (i_t.shape == i_s.shape == r_t.shape == r_s.shape):
        raise ValueError("size mismatch between frames")
    if not (np.all(np.isfinite(i_t)) and np.all(np.isfinite(i_s))):
        return float("inf")
    d = (i_t - i_s) - (r_t - r_s)
    return float(np.mean(d ** 2 / (((r_t + r_s) / 2) ** 2 + EPS)))


def frame_files(spec):
    """{frame number: path} for a pattern with one run of #, a glob or a folder."""
    if os.path.isdir(spec):
        paths = glob.glob(os.path.join(spec, "*.exr"))
    elif "#" in spec:
        runs = re.findall(r"#+", spec)
        if len(runs) != 1:
            raise ValueError(f"{spec}: a pattern needs one run of #")
        paths = glob.glob(glob.escape(spec).replace(glob.escape(runs[0]), "[0-9]" * len(runs[0])))
    else:
        paths = glob.glob(spec)
    out = {}
    for p in paths:
        nums = re.findall(r"\d+", os.path.basename(p))
        if nums:
            out[int(nums[-1])] = p
    return out


def reference_noise(spec):
    """{frame: noise_relmse} from a sequence.json next to the reference frames, if any."""
    d = spec if os.path.isdir(spec) else os.path.dirname(spec)
    path = os.path.join(d, "sequence.json")
    if not os.path.isfile(path):
        return {}
    with open(path) as f:
        return {row["frame"]: row.get("noise_relmse") for row in json.load(f).get("frames", [])}


def flicker(seq, ref, read):
    """Per-frame and temporal relMSE of frames {f: path} against reference frames {f: path}."""
    frames = sorted(set(seq) & set(ref))
    if not frames:
        raise ValueError("no frame is in both sequences")
    per_frame, pairs = [], []
    prev = None
    for f in frames:
        i, r = read(seq[f]), read(ref[f])
        per_frame.append({"frame": f, "relMSE": rel_mse(i, r), "mean": float(np.mean(i)),
                          "mean_ref": float(np.mean(r))})
        if prev is not None:
            pf, pi, pr = prev
            pairs.append({"frames": [pf, f], "relMSE": rel_mse_diff(i, pi, r, pr)})
        prev = (f, i, r)
    return per_frame, pairs


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("sequence", help="pattern (####), glob or folder of the rendered frames")
    ap.add_argument("reference", help="pattern, glob or folder of the reference frames")
    ap.add_argument("--json", action="store_true", help="print one JSON object")
    args = ap.parse_args()
    from mref_exr import read_rgb
    try:
        seq, ref = frame_files(args.sequence), frame_files(args.reference)
        per_frame, pairs = flicker(seq, ref, read_rgb)
    except (OSError, KeyError, ValueError, RuntimeError) as e:
        print(f"flicker: {e}", file=sys.stderr)
        return 2
    noise = reference_noise(args.reference)
    for row in per_frame:
        if row["frame"] in noise:
            row["reference_noise_relMSE"] = noise[row["frame"]]
    out = {
        "frames": len(per_frame),
        "relMSE_mean": float(np.mean([r["relMSE"] for r in per_frame])),
        "relMSE_max": float(np.max([r["relMSE"] for r in per_frame])),
        "temporal_relMSE": float(np.mean([p["relMSE"] for p in pairs])) if pairs else None,
        "per_frame": per_frame,
        "pairs": pairs,
        "definition": "relMSE_t = mean (I_t - R_t)^2 / (R_t^2 + 0.01); temporal = mean over consecutive "
                      "pairs of mean ((I_t - I_s) - (R_t - R_s))^2 / (((R_t + R_s)/2)^2 + 0.01)",
    }
    if args.json:
        print(json.dumps(out, indent=2))
        return 0
    print(f"{'frame':>6} {'relMSE':>11} {'flicker':>11} {'mean':>9} {'ref mean':>9}")
    flick = {p["frames"][1]: p["relMSE"] for p in pairs}
    for r in per_frame:
        fl = f"{flick[r['frame']]:11.4g}" if r["frame"] in flick else f"{'-':>11}"
        print(f"{r['frame']:>6} {r['relMSE']:11.4g} {fl} {r['mean']:9.4f} {r['mean_ref']:9.4f}")
    t = out["temporal_relMSE"]
    print(f"{out['frames']} frames: relMSE mean {out['relMSE_mean']:.4g} (max {out['relMSE_max']:.4g}), "
          f"temporal relMSE {t:.4g}" if t is not None else f"{out['frames']} frame: no pairs")
    return 0


if __name__ == "__main__":
    sys.exit(main())
