"""Bakes (made, saved, loaded, rendered) and sequences against the command line's frames."""

import numpy as np
import pytest

import pmrender as pm
from conftest import SCENES, REPO, cli

SMALL = dict(width=64, height=48)


@pytest.mark.parametrize(
    "path",
    [SCENES / "cornell-caustics.toml", SCENES / "fog-cornell.toml",
     REPO / "tests" / "scenes" / "cornell-glossy.toml"],
)
def test_a_render_from_a_bake_is_the_render(tmp_path, path):
    scene = pm.load_file(path, **SMALL)
    full = pm.render(scene, spp=4)
    b = pm.bake(scene, spp=4)
    assert b.method == "pm" and b.stats["icache"]["records_pass_a"] > 0
    assert np.array_equal(pm.render(scene, spp=4, bake=b).image, full.image)
    b.save(tmp_path / "scene.bake")
    loaded = pm.load_bake(tmp_path / "scene.bake")
    again = pm.render(scene, spp=4, bake=loaded)
    assert np.array_equal(again.image, full.image)
    assert again.stats["photons"]["paths_emitted"] == full.stats["photons"]["paths_emitted"]


def test_a_bake_refuses_another_scene_method_or_a_damaged_file(tmp_path):
    scene = pm.load_file(SCENES / "cornell-caustics.toml", **SMALL)
    b = pm.bake(scene, spp=2)
    other = pm.load_file(SCENES / "blinds-room.toml", **SMALL)
    with pytest.raises(ValueError, match="another scene"):
        pm.render(other, bake=b)
    with pytest.raises(ValueError, match="method"):
        pm.render(scene, method="photons", bake=b)
    with pytest.raises(ValueError, match="nothing to bake"):
        pm.bake(scene, method="path")
    with pytest.raises(ValueError, match="occlusion reads no photons; save ao's occlusion cache"):
        pm.bake(scene, method="ao")
    f = tmp_path / "b.bake"
    b.save(f)
    data = bytearray(f.read_bytes())
    data[len(data) // 2] ^= 0xFF
    f.write_bytes(bytes(data))
    with pytest.raises(ValueError, match="damaged"):
        pm.load_bake(f)
    (tmp_path / "short.bake").write_bytes(b"PMBAKE1\n\x01")
    with pytest.raises(ValueError):
        pm.load_bake(tmp_path / "short.bake")


def test_render_sequence_gives_the_clis_frames(tmp_path):
    scene = SCENES / "anim-ball.toml"
    cli("render", str(scene), "-o", str(tmp_path / "f-##.exr"), "--frames", "0..3",
        "--width", "48", "--height", "36", "--spp", "2", "--quiet")
    frames = list(pm.render_sequence(pm.load_file(scene, width=48, height=36),
                                     frames=range(0, 4), spp=2))
    assert [f for f, _ in frames] == [0, 1, 2, 3]
    for f, r in frames:
        cli_img = pm.read_image(tmp_path / f"f-{f:02}.exr")
        assert np.array_equal(r.image, cli_img), f
        assert r.stats["frame"]["index"] == f


def test_leaving_a_sequence_early_stops_it():
    scene = pm.load_file(SCENES / "anim-ball.toml", width=32, height=24)
    for f, r in pm.render_sequence(scene, spp=1):
        assert f == 0 and r.image.shape == (24, 32, 3)
        break
    # A new sequence runs after the abandoned one.
    assert [f for f, _ in pm.render_sequence(scene, frames=[5], spp=1)] == [5]


def test_a_walks_frames_from_its_bake_are_the_clis(tmp_path):
    scene = SCENES / "blinds-walk.toml"
    cli("render", str(scene), "-o", str(tmp_path / "f-##.exr"), "--frames", "5..6", "--shared-bake",
        "--width", "48", "--height", "36", "--spp", "2", "--quiet")
    s = pm.load_file(scene, width=48, height=36, spp=2)
    b = pm.bake(s)
    # The bake travels as bytes (to a farm's workers) and shades the same frames.
    shipped = pm.Bake.from_bytes(b.to_bytes())
    for f in (6, 5):
        r = pm.render(s, bake=shipped, frame=f)
        assert np.array_equal(r.image, pm.read_image(tmp_path / f"f-{f:02}.exr")), f
        assert r.stats["frame"]["index"] == f
    with pytest.raises(ValueError, match="frame"):
        pm.render(s, frame=3)
    with pytest.raises(ValueError, match="frames 0..=23"):
        pm.render(s, bake=b, frame=24)
    with pytest.raises(ValueError, match="moves a mesh"):
        pm.bake(pm.load_file(SCENES / "anim-ball.toml", width=48, height=36))
