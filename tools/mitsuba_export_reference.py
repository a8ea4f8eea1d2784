#!/usr/bin/env python3
"""A reference image of a still pmrender scene as `pmrender export-mitsuba` writes it, rendered by
Mitsuba 3's `path` integrator.

Usage (from the repo root, after `cargo build --release`; Mitsuba from `pip install -r tools/requirements.txt`):
    python3 tools/mitsuba_export_reference.py SCENE.toml OUT.exr --width W --height H [--spp N]
                                              [--passes P] [--variant V] [--bin target/release/pmrender]

Where tools/mitsuba_reference.py reads the scene with its own Python loader (which knows no bump or
normal maps, cutouts or media), this one renders what the renderer's exporter makes of it: bump maps
as Mitsuba's `bumpmap`, normal maps as `normalmap`, cutouts as `mask`. The film is resized to W x H;
passes, variant and noise estimate are mitsuba_reference.py's. Writes OUT.exr (linear RGB float32) and
OUT.json beside it: the command, Mitsuba's version and variant, spp, time, and the reference's own
noise (noise_relmse: the relMSE by which it is expected to differ from the exact image).
"""
import argparse
import json
import os
import re
import subprocess
import sys
import tempfile
import time

import numpy as np

TOOLS = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, TOOLS)


def export(binary, scene, spp, width, height):
    """The scene exported into a temporary folder, its film set to width x height; the XML's path."""
    out = os.path.join(tempfile.mkdtemp(prefix="mitsuba-export-"), "x")
    r = subprocess.run([binary, "export-mitsuba", scene, out, "--spp", str(spp)], capture_output=True, text=True)
    if r.returncode != 0:
        raise SystemExit(f"export-mitsuba: {r.stderr.strip()}")
    xml = os.path.join(out, "scene.xml")
    with open(xml) as f:
        text = f.read()
    text = re.sub(r'<integer name="width" value="\d+"/>', f'<integer name="width" value="{width}"/>', text)
    text = re.sub(r'<integer name="height" value="\d+"/>', f'<integer name="height" value="{height}"/>', text)
    with open(xml, "w") as f:
        f.write(text)
    return xml


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("scene")
    ap.add_argument("out")
    ap.add_argument("--width", type=int, required=True)
    ap.add_argument("--height", type=int, required=True)
    ap.add_argument("--spp", type=int, default=1024)
    ap.add_argument("--passes", type=int, default=8, help="independent passes, for the noise estimate")
    ap.add_argument("--variant", help="Mitsuba variant (default: llvm_ad_rgb if usable, else scalar_rgb)")
    ap.add_argument("--bin", default=os.path.join(os.path.dirname(TOOLS), "target", "release", "pmrender"))
    args = ap.parse_args()

    from mitsuba_reference import pick_variant, render_passes
    mi, variant = pick_variant(args.variant)
    import mref_phong
    mref_phong.register()
    xml = export(args.bin, args.scene, args.spp, args.width, args.height)
    with open(xml) as f:
        text = f.read()
    integrator = re.search(r'<integrator type="(\w+)"', text)
    scene = mi.load_file(xml)

    t0, c0 = time.time(), time.process_time()
    mean, se, image_se, spp_done = render_passes(mi, scene, args.spp, max(1, args.passes), 0,
                                                 args.width, args.height, variant)
    wall, cpu = time.time() - t0, time.process_time() - c0

    from mref_exr import write_rgb
    os.makedirs(os.path.dirname(os.path.abspath(args.out)), exist_ok=True)
    write_rgb(args.out, mean)
    info = {
        "scene": os.path.relpath(os.path.abspath(args.scene), os.path.dirname(os.path.abspath(args.out))),
        "command": " ".join(["python3", "tools/mitsuba_export_reference.py"] + sys.argv[1:]),
        "exported_by": "pmrender export-mitsuba",
        "renderer": f"mitsuba {mi.__version__}", "variant": variant,
        "integrator": integrator.group(1) if integrator else "?",
        "width": args.width, "height": args.height, "spp": spp_done, "passes": max(1, args.passes), "seed": 0,
        "time_wall_s": round(wall, 2), "time_cpu_s": round(cpu, 2),
        "stderr_mean": float(np.mean(se)), "stderr_max": float(np.max(se)),
        "noise_relmse": float(np.mean(se ** 2 / (mean ** 2 + 0.01))),
        "mean_value": float(np.mean(mean)),
        "image_mean_rel_stderr": [float(x) for x in image_se],
        "bsdf_wrappers": {w: text.count(f'<bsdf type="{w}"') for w in ("bumpmap", "normalmap", "mask")},
    }
    with open(os.path.splitext(args.out)[0] + ".json", "w") as f:
        json.dump(info, f, indent=2)
        f.write("\n")
    print(json.dumps(info, indent=2))


if __name__ == "__main__":
    main()
