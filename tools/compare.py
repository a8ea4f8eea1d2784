#!/usr/bin/env python3
"""Relative MSE of an image against a reference, for tests and reports.

Usage:
    python3 tools/compare.py A.exr B.exr [--layer NAME] [--max T] [--json]

B is the reference r. Prints
    relMSE = mean over pixels and channels of (a - r)^2 / (r^2 + 0.01)
(plus the plain MSE and the mean values). With --max T, exits 1 when relMSE > T (and 2 on a size
mismatch or unreadable file). --layer compares A's layer NAME (channels NAME.R/G/B, as pmrender's
layered EXR writes them) instead of its beauty R,G,B. Non-finite pixels in A count as a failure
(they are reported and make relMSE infinite).

Reads EXR with OpenImageIO's Python bindings when importable, else with Mitsuba's Bitmap
(`pip install -r tools/requirements.txt`).
"""
import argparse
import json
import os
import sys

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))


def rel_mse(a, r):
    a, r = np.asarray(a, dtype=np.float64), np.asarray(r, dtype=np.float64)
    if a.shape != r.shape:
        raise ValueError(f"size mismatch: {a.shape} vs {r.shape}")
    if not np.all(np.isfinite(a)):
        return float("inf")
    return float(np.mean((a - r) ** 2 / (r ** 2 + 0.01)))


def main():
    ap = argparse.ArgumentParser(description="relMSE of A against reference B")
    ap.add_argument("a")
    ap.add_argument("b", help="the reference")
    ap.add_argument("--layer", help="compare this layer of A (NAME.R, NAME.G, NAME.B)")
    ap.add_argument("--max", type=float, help="exit 1 if relMSE exceeds this")
    ap.add_argument("--json", action="store_true", help="print one JSON object")
    args = ap.parse_args()
    from mref_exr import read_rgb
    try:
        a = read_rgb(args.a, args.layer)
        r = read_rgb(args.b)
        value = rel_mse(a, r)
    except (OSError, KeyError, ValueError, RuntimeError) as e:
        print(f"compare: {e}", file=sys.stderr)
        return 2
    finite = np.isfinite(a)
    out = {"relMSE": value, "mse": float(np.mean((np.where(finite, a, 0) - r) ** 2)),
           "mean_a": float(np.mean(np.where(finite, a, 0))), "mean_ref": float(np.mean(r)),
           "nonfinite_a": int(np.size(a) - np.count_nonzero(finite)), "shape": list(r.shape)}
    if args.json:
        print(json.dumps(out))
    else:
        print(f"relMSE {value:.6g}  (mse {out['mse']:.6g}, mean {out['mean_a']:.6g} vs ref {out['mean_ref']:.6g}"
              + (f", {out['nonfinite_a']} non-finite values in A" if out["nonfinite_a"] else "") + ")")
    if args.max is not None and not value <= args.max:
        print(f"relMSE {value:.6g} > {args.max}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
