#!/usr/bin/env python3
"""Independent reference sequence for an animated pmrender scene, rendered by Mitsuba 3.

Usage (from the repo root, after `cargo build --release`; Mitsuba from `pip install -r tools/requirements.txt`):
    python3 tools/mitsuba_sequence.py SCENE.toml OUTDIR [--frames A..B] [--step K] [--spp N]
                                      [--width W --height H] [--passes P] [--variant V]
                                      [--seed-offset N] [--bin target/release/pmrender]

Each frame f is exported by `pmrender export-mitsuba SCENE DIR --frame f` (so the frame's camera,
mesh placements and lights are pmrender's own interpolation of the keys), its film resized to
--width x --height, and rendered with Mitsuba's `path` integrator (tools/mitsuba_reference.py's
variant choice and passes). Writes OUTDIR/frame-NNNN.exr (linear RGB, R,G,B; half floats with --half: a relative rounding of
at most 2^-11, far below the reference's noise, for half the bytes) and
OUTDIR/sequence.json: how it was made (command, Mitsuba version and variant, spp, size, CPU and wall
time) and per frame its mean value and its own noise (noise_relmse, from P independent passes, as in
mitsuba_reference.py: the relMSE by which the reference frame is expected to differ from the exact one).

Every frame is rendered with the same sampler seeds (pass k of every frame uses seed k): where the ball
(or whatever moves) does not change a path, consecutive frames get the same samples and the same value,
so R_t - R_(t-1), which tools/flicker.py compares a sequence's frame differences against, holds the
change of the scene and little of the reference's own noise.
"""
import argparse
import json
import math
import os
import re
import subprocess
import sys
import tempfile
import time

import numpy as np

TOOLS = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, TOOLS)


def frame_list(spec, step, frames):
    a, b = 0, frames - 1
    if spec:
        lo, _, hi = spec.partition("..")
        a, b = int(lo), int(hi or lo)
    if not (0 <= a <= b < frames):
        raise SystemExit(f"--frames {spec}: outside 0..{frames - 1}")
    return list(range(a, b + 1, max(1, step)))


def animation_frames(scene):
    import tomllib
    with open(scene, "rb") as f:
        anim = tomllib.load(f).get("animation")
    if not anim:
        raise SystemExit(f"{scene}: no [animation] (use tools/mitsuba_reference.py for a still)")
    return int(anim["frames"])


def export_frame(binary, scene, f, spp, width, height):
    """The frame's Mitsuba scene in a temporary folder, its film set to width x height; the XML path."""
    d = tempfile.mkdtemp(prefix=f"mitsuba-seq-{f:04d}-")
    out = os.path.join(d, "x")
    r = subprocess.run([binary, "export-mitsuba", scene, out, "--frame", str(f), "--spp", str(spp)],
                       capture_output=True, text=True)
    if r.returncode != 0:
        raise SystemExit(f"export-mitsuba frame {f}: {r.stderr.strip()}")
    xml = os.path.join(out, "scene.xml")
    text = open(xml).read()
    text = re.sub(r'<integer name="width" value="\d+"/>', f'<integer name="width" value="{width}"/>', text)
    text = re.sub(r'<integer name="height" value="\d+"/>', f'<integer name="height" value="{height}"/>', text)
    with open(xml, "w") as fh:
        fh.write(text)
    return xml


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("scene")
    ap.add_argument("outdir")
    ap.add_argument("--frames", help="A..B inclusive (default: all)")
    ap.add_argument("--step", type=int, default=1, help="every K-th frame of the range")
    ap.add_argument("--spp", type=int, default=1024)
    ap.add_argument("--width", type=int, required=True)
    ap.add_argument("--height", type=int, required=True)
    ap.add_argument("--passes", type=int, default=4, help="independent passes per frame, for its noise")
    ap.add_argument("--variant", help="Mitsuba variant (default: llvm_ad_rgb if usable, else scalar_rgb)")
    ap.add_argument("--half", action="store_true", help="write half-float EXRs")
    ap.add_argument("--seed-offset", type=int, default=0,
                    help="seed of every frame (default 0); another value gives an independent sequence")
    ap.add_argument("--bin", default=os.path.join(os.path.dirname(TOOLS), "target", "release", "pmrender"))
    args = ap.parse_args()

    frames = frame_list(args.frames, args.step, animation_frames(args.scene))
    from mitsuba_reference import pick_variant, render_passes
    mi, variant = pick_variant(args.variant)
    import mref_phong
    mref_phong.register()

    def write_rgb(path, img):
        bmp = mi.Bitmap(np.ascontiguousarray(img, dtype=np.float32), mi.Bitmap.PixelFormat.RGB)
        if args.half:
            bmp = bmp.convert(mi.Bitmap.PixelFormat.RGB, mi.Struct.Type.Float16, False)
        bmp.write(path)

    os.makedirs(args.outdir, exist_ok=True)
    rows = []
    t0, c0 = time.time(), time.process_time()
    for f in frames:
        xml = export_frame(args.bin, args.scene, f, args.spp, args.width, args.height)
        scene = mi.load_file(xml)
        tf, cf = time.time(), time.process_time()
        # the same seed for every frame (0 unless --seed-offset): render_passes seeds pass k's calls from it.
        mean, se, _image_se, spp_done = render_passes(mi, scene, args.spp, max(1, args.passes),
                                                      args.seed_offset, args.width, args.height, variant)
        write_rgb(os.path.join(args.outdir, f"frame-{f:04d}.exr"), mean)
        rows.append({"frame": f, "mean_value": float(np.mean(mean)),
                     "stderr_mean": float(np.mean(se)),
                     "noise_relmse": float(np.mean(se ** 2 / (mean ** 2 + 0.01))),
                     "time_wall_s": round(time.time() - tf, 2), "time_cpu_s": round(time.process_time() - cf, 2)})
        print(f"frame {f}: mean {rows[-1]['mean_value']:.4f}, noise relMSE {rows[-1]['noise_relmse']:.3g}, "
              f"{rows[-1]['time_wall_s']} s", file=sys.stderr)
    info = {
        "scene": os.path.relpath(os.path.abspath(args.scene), os.path.abspath(args.outdir)),
        "command": " ".join(["python3", "tools/mitsuba_sequence.py"] + sys.argv[1:]),
        "exported_by": "pmrender export-mitsuba --frame F",
        "renderer": f"mitsuba {mi.__version__}", "variant": variant, "integrator": "path",
        "width": args.width, "height": args.height, "spp": spp_done, "passes": max(1, args.passes),
        "seeds": "the same in every frame (pass k: seed k), so unchanged paths give unchanged values",
        **({"seed_offset": args.seed_offset} if args.seed_offset else {}),
        "files": "frame-NNNN.exr" + (" (half floats)" if args.half else ""),
        "time_wall_s": round(time.time() - t0, 2), "time_cpu_s": round(time.process_time() - c0, 2),
        "noise_relmse_mean": float(np.mean([r["noise_relmse"] for r in rows])),
        "frames": rows,
    }
    with open(os.path.join(args.outdir, "sequence.json"), "w") as fh:
        json.dump(info, fh, indent=2)
        fh.write("\n")
    print(json.dumps({k: v for k, v in info.items() if k != "frames"}, indent=2))


if __name__ == "__main__":
    main()
