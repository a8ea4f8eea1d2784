"""The module's renders against the command line's: the same pixels, layers and statistics."""

import json

import numpy as np
import pytest

import pmrender as pm
from conftest import SCENES, cli

SMALL = dict(width=64, height=48)


def timeless(d):
    """The statistics without what depends on the clock or the process (times, memory)."""
    if isinstance(d, dict):
        return {
            k: timeless(v)
            for k, v in d.items()
            if k not in ("time", "memory") and not k.endswith("_s")
        }
    return d


@pytest.mark.parametrize(
    "name, method",
    [("cornell-caustics", "pm"), ("fog-spot", "pm"), ("water-caustics", "photons"), ("spot-point", "path"),
     ("blinds-room", "ao")],
)
def test_pixels_layers_and_stats_are_the_clis(tmp_path, name, method):
    scene = SCENES / f"{name}.toml"
    exr, js = tmp_path / "cli.exr", tmp_path / "cli.json"
    cli("render", str(scene), "-o", str(exr), "--stats", str(js), "--method", method,
        "--width", "64", "--height", "48", "--spp", "4", "--quiet")
    r = pm.render(pm.load_file(scene, **SMALL), method=method, spp=4)
    assert r.image.shape == (48, 64, 3) and r.image.dtype == np.float32
    assert np.array_equal(r.image, pm.read_image(exr))
    for layer, img in r.layers.items():
        assert np.array_equal(img, pm.read_image(exr, layer)), layer
    assert timeless(r.stats) == timeless(json.loads(js.read_text()))


def test_the_written_exr_is_the_clis_byte_for_byte(tmp_path):
    scene = SCENES / "cornell-caustics.toml"
    cli("render", str(scene), "-o", str(tmp_path / "cli.exr"), "--width", "64", "--height", "48",
        "--spp", "4", "--quiet")
    r = pm.render(pm.load_file(scene, **SMALL), spp=4)
    r.write(tmp_path / "py.exr", png=tmp_path / "py.png", stats=tmp_path / "py.json")
    assert (tmp_path / "py.exr").read_bytes() == (tmp_path / "cli.exr").read_bytes()
    assert (tmp_path / "py.png").stat().st_size > 0
    assert json.loads((tmp_path / "py.json").read_text())["render"]["method"] == "pm"


@pytest.mark.parametrize("name", ["cornell-caustics", "fog-cornell", "blinds-room"])
def test_layers_sum_to_the_image(name):
    r = pm.render(pm.load_file(SCENES / f"{name}.toml", **SMALL), spp=4)
    total = sum(r.layers.values())
    assert set(r.layers) >= {"direct", "caustic", "indirect"}
    np.testing.assert_allclose(total, r.image, rtol=1e-5, atol=1e-6)


def test_the_thread_count_changes_no_pixel():
    scene = pm.load_file(SCENES / "blinds-room.toml", **SMALL)
    one = pm.render(scene, spp=4, threads=1)
    two = pm.render(scene, spp=4, threads=2)
    assert np.array_equal(one.image, two.image)


def test_render_arguments_override_load_files():
    scene = pm.load_file(SCENES / "cornell-caustics.toml", width=40, height=30, spp=2)
    assert scene.size == (40, 30)
    r = pm.render(scene, width=32, height=24)
    assert (r.width, r.height) == (32, 24)
    assert r.stats["image"]["spp"] == 2


def test_seeds_change_the_noise_and_only_the_noise():
    scene = pm.load_file(SCENES / "cornell-caustics.toml", **SMALL)
    a, b = (pm.render(scene, spp=4, seed=s).image for s in (0, 1))
    assert not np.array_equal(a, b)
    # Image means over seeds 0-9 (the command line's renders at these settings): 0.1436-0.1523,
    # sd 1.9 %, so a ratio of two seeds has an sd of 2.7 %; seeds 0 and 1 give 0.9615 (0.9603 on
    # SSE4.2's kernels), the worst of the 45 pairs 0.942. The bound was 5 %, 1.3x seed 0/1's
    # distance: 10 % (3.7 sd), still under a seed that moved more than the noise.
    assert abs(a.mean() / b.mean() - 1) < 0.10


def test_an_assets_undefined_material_is_a_render_warning(tmp_path):
    (tmp_path / "box.obj").write_text(
        "mtllib box.mtl\nv -1 0 -1\nv 1 0 -1\nv 1 0 1\nv -1 0 1\nusemtl nowhere\nf 1 2 3\nf 1 3 4\n")
    (tmp_path / "box.mtl").write_text("newmtl floor\nKd 0.5 0.5 0.5\n")
    (tmp_path / "s.toml").write_text(
        '[camera]\neye = [0, 2, 3]\ntarget = [0, 0, 0]\nfov = 40\nwidth = 16\nheight = 12\n\n'
        '[[mesh]]\nobj = "box.obj"\n\n[[light]]\ntype = "point"\nposition = [0, 2, 0]\n'
        'intensity = [5, 5, 5]\n')
    with pytest.warns(pm.RenderWarning, match="nowhere"):
        r = pm.render(pm.load_file(tmp_path / "s.toml"), spp=1)
    assert any("box.obj:6" in w for w in r.warnings)
