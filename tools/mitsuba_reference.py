#!/usr/bin/env python3
"""Independent reference images for pmrender scenes, rendered by Mitsuba 3's `path` integrator.

Usage (from anywhere; install first with `pip install -r tools/requirements.txt`):
    python3 tools/mitsuba_reference.py SCENE.toml OUT.exr [--spp N] [--width W --height H]
                                       [--xml-dir DIR] [--passes K] [--variant V]

Reads pmrender's TOML scene format (camera, [[mesh]] OBJ/MTL with scale/rotate/translate,
[materials.NAME] overrides, [[light]] point/spot/directional, [render] spp/seed/max_depth), writes it
as a Mitsuba 3 scene (scene.xml + one OBJ per material group, into --xml-dir or a temporary folder)
and renders it: `path` integrator (max_depth = ours + 1, see mref_export.py), hide_emitters false,
`perspective` sensor with fov_axis="y", box reconstruction filter, `independent` sampler.

Writes OUT.exr (linear RGB float32, channels R,G,B) and OUT.json (same name, .json) with:
spp, passes, time (wall and CPU seconds), the Mitsuba version and variant, and the noise of the
reference itself, from K independent passes with different seeds:
  stderr_mean        mean over pixels and channels of the standard error of the mean
  image_mean_rel_stderr  per channel, the standard error of the image mean over the image mean
  noise_relmse       mean of stderr^2 / (ref^2 + 0.01): the relMSE (tools/compare.py's metric) by which
                     this reference is expected to differ from the exact image
Variant: llvm_ad_rgb when it works (needs libLLVM: Debian's libllvm19; DRJIT_LIBLLVM_PATH is set here
if it is unset and the library is found), else scalar_rgb. Force one with --variant.

Glossy materials use pm_phong, a Python BSDF plugin reproducing pmrender's modified Phong
(tools/mref_phong.py); with scalar_rgb it is slow (Python is called per interaction).
Spot lights: cutoff_angle = cone_angle, beam_width = falloff_start; pmrender's falloff in between is
Mitsuba's own (linear in the angle), so they agree.
"""
import argparse
import glob
import json
import math
import os
import sys
import tempfile
import time

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

LLVM_CANDIDATES = ["/usr/lib/x86_64-linux-gnu/libLLVM-19.so", "/usr/lib/llvm-19/lib/libLLVM.so*",
                   "/usr/lib/x86_64-linux-gnu/libLLVM*.so*", "/usr/lib/llvm-*/lib/libLLVM*.so*"]
MAX_LANES = 1 << 22  # samples per mi.render call in JIT variants (memory bound)


def pick_variant(forced):
    if "DRJIT_LIBLLVM_PATH" not in os.environ:
        for pattern in LLVM_CANDIDATES:
            found = sorted(glob.glob(pattern))
            if found:
                os.environ["DRJIT_LIBLLVM_PATH"] = found[-1]
                break
    import drjit as dr
    import mitsuba as mi
    for v in ([forced] if forced else ["llvm_ad_rgb", "scalar_rgb"]):
        try:
            mi.set_variant(v)
            x = mi.Float(1.0) + 1.0
            dr.eval(x)
            return mi, v
        except Exception as e:  # noqa: BLE001 - any failure means: try the next variant
            print(f"variant {v} unavailable: {e}", file=sys.stderr)
    raise SystemExit("no usable Mitsuba variant")


def render_passes(mi, scene, spp, passes, seed, width, height, variant):
    """Returns (mean image, per-pixel standard error, the image mean's relative standard error per
    channel, spp actually rendered)."""
    per_pass = max(1, math.ceil(spp / passes))
    chunk = per_pass if variant.startswith("scalar") else max(1, min(per_pass, MAX_LANES // (width * height)))
    images, call = [], 0
    for k in range(passes):
        acc, done = np.zeros((height, width, 3)), 0
        while done < per_pass:
            n = min(chunk, per_pass - done)
            img = mi.render(scene, spp=n, seed=seed * 1_000_003 + call)
            acc += np.array(img, dtype=np.float64)[:, :, :3] * n
            done, call = done + n, call + 1
        images.append(acc / per_pass)
        print(f"pass {k + 1}/{passes}: {per_pass} spp", file=sys.stderr)
    stack = np.stack(images)
    mean = stack.mean(axis=0)
    se = stack.std(axis=0, ddof=1) / math.sqrt(passes) if passes > 1 else np.full_like(mean, np.nan)
    # The passes' image means spread by the noise of the whole image's mean, which per-pixel errors
    # understate where a few samples carry much of it (a point light inside a medium).
    pass_means = stack.mean(axis=(1, 2))
    image_se = (pass_means.std(axis=0, ddof=1) / math.sqrt(passes) / np.maximum(mean.mean(axis=(0, 1)), 1e-12)
                if passes > 1 else np.full(3, np.nan))
    return mean, se, image_se, per_pass * passes


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("scene")
    ap.add_argument("out")
    ap.add_argument("--spp", type=int, help="samples per pixel (default: [render] spp, else 256)")
    ap.add_argument("--width", type=int)
    ap.add_argument("--height", type=int)
    ap.add_argument("--xml-dir", help="where to write scene.xml and its OBJs (default: a temporary folder)")
    ap.add_argument("--passes", type=int, default=8, help="independent passes for the error estimate")
    ap.add_argument("--variant", help="Mitsuba variant (default: llvm_ad_rgb if usable, else scalar_rgb)")
    args = ap.parse_args()

    from mref_load import load
    from mref_scene import SceneError
    try:
        scene = load(args.scene)
    except (SceneError, KeyError, ValueError, OSError) as e:
        raise SystemExit(f"{args.scene}: {e}")
    width = args.width or scene.camera["width"]
    height = args.height or scene.camera["height"]
    spp = args.spp or scene.spp or 256

    mi, variant = pick_variant(args.variant)
    import mref_export
    import mref_phong
    mref_phong.register()
    xml_dir = args.xml_dir or tempfile.mkdtemp(prefix="mitsuba-ref-")
    xml = mref_export.export(scene, xml_dir, spp, width, height)
    mscene = mi.load_file(xml)

    t0, c0 = time.time(), time.process_time()
    mean, se, image_se, spp_done = render_passes(mi, mscene, spp, max(1, args.passes), scene.seed, width, height, variant)
    wall, cpu = time.time() - t0, time.process_time() - c0

    from mref_exr import write_rgb
    os.makedirs(os.path.dirname(os.path.abspath(args.out)), exist_ok=True)
    write_rgb(args.out, mean)
    glossy = [m.name for m in scene.materials if m.kind == "glossy"]
    info = {
        "scene": os.path.relpath(scene.path, os.path.dirname(os.path.abspath(args.out))),
        "command": " ".join(["python3", "tools/mitsuba_reference.py"] + sys.argv[1:]),
        "renderer": f"mitsuba {mi.__version__}", "variant": variant,
        "integrator": "volpath" if scene.boundaries else "path",
        "max_depth_pmrender": scene.max_depth, "max_depth_mitsuba": scene.max_depth + 1,
        "width": width, "height": height, "spp": spp_done, "passes": max(1, args.passes), "seed": scene.seed,
        "time_wall_s": round(wall, 2), "time_cpu_s": round(cpu, 2),
        "stderr_mean": float(np.mean(se)), "stderr_max": float(np.max(se)),
        "noise_relmse": float(np.mean(se ** 2 / (mean ** 2 + 0.01))),
        "mean_value": float(np.mean(mean)),
        "image_mean_rel_stderr": [float(x) for x in image_se],
        "notes": (["glossy materials use the pm_phong Python plugin (modified Phong as pmrender): "
                   + ", ".join(glossy)] if glossy else [])
                 + (["media: homogeneous, HG phase, attached to their boundary shapes (interior/exterior as "
                     "pmrender finds them); the llvm variants failed to compile volpath here, so scalar_rgb"]
                    if scene.boundaries else []),
    }
    with open(os.path.splitext(args.out)[0] + ".json", "w") as f:
        json.dump(info, f, indent=2)
    print(json.dumps(info, indent=2))


if __name__ == "__main__":
    main()
