#!/usr/bin/env python3
"""An independent ambient-occlusion reference for pmrender scenes, brute force on Mitsuba 3's ray casting.

Usage (from anywhere; install first with `pip install -r tools/requirements.txt`):
    python3 tools/mref_ao.py SCENE.toml OUT.exr [--spp N] [--rays N] [--width W --height H]
                             [--distance D] [--passes K] [--seed S] [--variant V]

Mitsuba 3 has no occlusion integrator (its `aov` integrator gives depth, normals, positions, indices:
no occlusion), so this computes the quantity pmrender's `ao` and `ao-direct` define, with none of
pmrender's code: the scene is read by tools/mref_load.py and written as Mitsuba XML by
tools/mref_export.py (as for tools/mitsuba_reference.py), then for each camera sample (uniform in the
pixel, the `perspective` sensor's ray) at its first hit, `--rays` independent cosine-weighted
directions about the geometric normal turned toward the camera (`si.n`, Mitsuba's geometric normal)
are tested with `scene.ray_test` up to `maxt = D`; the pixel is the open fraction over all of them
(0 where the camera ray meets nothing), the same in R, G and B. D is `--distance`, else the scene's
`[render] ao_distance`, else a tenth of the diagonal of the triangles' bounding box (pmrender's default).
Materials and lights play no part: every triangle occludes, an emitter's too.

Writes OUT.exr (float32 R,G,B) and OUT.json (same name) with the command, D, the sample counts, the
time, and the reference's own noise from K passes of different seeds (`noise_relmse`: the mean of
stderr² / (ref² + 0.01), tools/compare.py's metric, by which this image is expected to differ from
the exact occlusion). Scenes with participating media are refused: their invisible boundaries are no
surface to pmrender's occlusion, and here every triangle is one.
"""
import argparse
import json
import math
import os
import sys
import tempfile
import time
import tomllib

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

from mitsuba_reference import pick_variant  # noqa: E402

MAX_LANES = 1 << 21  # camera samples per batch (memory bound)


def ao_distance(scene, given):
    """--distance, else [render] ao_distance, else a tenth of the triangles' bounding-box diagonal."""
    if given is not None:
        return given
    with open(scene.path, "rb") as f:
        d = tomllib.load(f).get("render", {}).get("ao_distance")
    if d is not None:
        return float(d)
    lo = [min(p[k] for t in scene.triangles for p in t.p) for k in range(3)]
    hi = [max(p[k] for t in scene.triangles for p in t.p) for k in range(3)]
    return 0.1 * math.dist(lo, hi)


def open_fraction(mi, mscene, pixels, width, height, rays, distance, rng):
    """The open fraction seen by one camera sample in each of `pixels` (flat indices): a float64 array."""
    import drjit as dr
    n = len(pixels)
    u = rng.random((2, n))
    pos = mi.Point2f(mi.Float(((pixels % width) + u[0]) / width), mi.Float(((pixels // width) + u[1]) / height))
    sensor = mscene.sensors()[0]
    ray, _ = sensor.sample_ray(0.0, 0.0, pos, mi.Point2f(0.5, 0.5))
    si = mscene.ray_intersect(ray)
    # The geometric normal turned toward the camera.
    ng = dr.select(dr.dot(si.n, ray.d) > 0.0, -si.n, si.n)
    frame = mi.Frame3f(ng)
    n_open = mi.Float(0.0)
    for _ in range(rays):
        # Cosine-weighted about +z (Malley), in numpy: mi.warp's safe_sqrt compiles to an LLVM
        # intrinsic that LLVM 15 cannot select on x86-64.
        s = rng.random((2, n))
        r, phi = np.sqrt(s[0]), 2.0 * math.pi * s[1]
        local = mi.Vector3f(mi.Float(r * np.cos(phi)), mi.Float(r * np.sin(phi)), mi.Float(np.sqrt(1.0 - s[0])))
        shadow = si.spawn_ray(frame.to_world(local))
        shadow.maxt = distance
        n_open += dr.select(mscene.ray_test(shadow, si.is_valid()), 0.0, 1.0)
        dr.eval(n_open)
    value = dr.select(si.is_valid(), n_open / rays, 0.0)
    return np.array(value, dtype=np.float64)


def render_pass(mi, mscene, width, height, spp, rays, distance, seed):
    """One pass: the mean open fraction of `spp` camera samples per pixel, (height, width)."""
    rng = np.random.default_rng(seed)
    acc = np.zeros(width * height)
    per_batch = max(1, MAX_LANES // (width * height))
    done = 0
    while done < spp:
        k = min(per_batch, spp - done)
        pixels = np.repeat(np.arange(width * height, dtype=np.int64), k)
        acc += open_fraction(mi, mscene, pixels, width, height, rays, distance, rng).reshape(-1, k).sum(axis=1)
        done += k
    return (acc / spp).reshape(height, width)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("scene")
    ap.add_argument("out")
    ap.add_argument("--spp", type=int, default=64, help="camera samples per pixel (default 64)")
    ap.add_argument("--rays", type=int, default=64, help="occlusion rays per camera sample (default 64)")
    ap.add_argument("--width", type=int)
    ap.add_argument("--height", type=int)
    ap.add_argument("--distance", type=float, help="occlusion distance (default: the scene's, as pmrender)")
    ap.add_argument("--passes", type=int, default=4, help="independent passes for the error estimate")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--variant", help="Mitsuba variant (default: llvm_ad_rgb if usable, else scalar_rgb)")
    args = ap.parse_args()
    if args.spp < 1 or args.rays < 1 or args.passes < 1:
        raise SystemExit("--spp, --rays and --passes must be at least 1")

    from mref_load import load
    from mref_scene import SceneError
    try:
        scene = load(args.scene)
    except (SceneError, KeyError, ValueError, OSError) as e:
        raise SystemExit(f"{args.scene}: {e}")
    if scene.boundaries:
        raise SystemExit(f"{args.scene}: scenes with media are not supported (their boundaries are no "
                         "surface to pmrender's occlusion)")
    width = args.width or scene.camera["width"]
    height = args.height or scene.camera["height"]
    distance = ao_distance(scene, args.distance)
    if not distance > 0.0:
        raise SystemExit(f"{args.scene}: the occlusion distance must be positive, not {distance}")

    mi, variant = pick_variant(args.variant)
    import mref_export
    import mref_phong
    mref_phong.register()
    xml = mref_export.export(scene, tempfile.mkdtemp(prefix="mitsuba-ao-"), 1, width, height)
    mscene = mi.load_file(xml)

    t0, c0 = time.time(), time.process_time()
    per_pass = max(1, math.ceil(args.spp / args.passes))
    images = []
    for k in range(args.passes):
        images.append(render_pass(mi, mscene, width, height, per_pass, args.rays, distance,
                                  args.seed * 1_000_003 + k))
        print(f"pass {k + 1}/{args.passes}: {per_pass} spp", file=sys.stderr)
    wall, cpu = time.time() - t0, time.process_time() - c0
    stack = np.stack(images)
    mean = stack.mean(axis=0)
    se = (stack.std(axis=0, ddof=1) / math.sqrt(args.passes) if args.passes > 1
          else np.full_like(mean, np.nan))

    from mref_exr import write_rgb
    os.makedirs(os.path.dirname(os.path.abspath(args.out)), exist_ok=True)
    write_rgb(args.out, np.repeat(mean[:, :, None], 3, axis=2))
    info = {
        "scene": os.path.relpath(scene.path, os.path.dirname(os.path.abspath(args.out))),
        "command": " ".join(["python3", "tools/mref_ao.py"] + sys.argv[1:]),
        "renderer": f"mitsuba {mi.__version__} ray casting (tools/mref_ao.py)", "variant": variant,
        "quantity": "cosine-weighted open fraction about the geometric normal turned toward the camera, "
                    "rays up to ao_distance",
        "ao_distance": distance, "width": width, "height": height,
        "spp": per_pass * args.passes, "rays_per_sample": args.rays, "passes": args.passes, "seed": args.seed,
        "time_wall_s": round(wall, 2), "time_cpu_s": round(cpu, 2),
        "stderr_mean": float(np.mean(se)), "stderr_max": float(np.max(se)),
        "noise_relmse": float(np.mean(se ** 2 / (mean ** 2 + 0.01))),
        "mean_value": float(np.mean(mean)),
    }
    with open(os.path.splitext(args.out)[0] + ".json", "w") as f:
        json.dump(info, f, indent=2)
    print(json.dumps(info, indent=2))


if __name__ == "__main__":
    main()
