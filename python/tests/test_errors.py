"""Bad scenes raise SceneError with the file and line; bad arguments raise ValueError; nothing
crashes the interpreter."""

import pytest

import pmrender as pm
from conftest import SCENES

CAMERA = '[camera]\neye = [0, 1, 3]\ntarget = [0, 1, 0]\n'


def test_a_bad_key_names_its_file_and_line(tmp_path):
    bad = tmp_path / "bad.toml"
    bad.write_text(CAMERA + 'fov = "wide"\n')
    with pytest.raises(pm.SceneError) as e:
        pm.load_file(bad)
    assert e.value.path == str(bad)
    assert e.value.line == 4
    assert str(bad) in str(e.value)


def test_a_missing_scene_file_is_a_scene_error_or_value_error(tmp_path):
    with pytest.raises(ValueError):
        pm.load_file(tmp_path / "none.toml")


def test_a_missing_obj_names_the_scene_file(tmp_path):
    bad = tmp_path / "obj.toml"
    bad.write_text(CAMERA + 'fov = 40\n\n[[mesh]]\nfile = "nowhere.obj"\n')
    with pytest.raises(pm.SceneError) as e:
        pm.load_file(bad)
    assert e.value.path == str(bad)
    assert isinstance(e.value.line, int)


@pytest.mark.parametrize(
    "kwargs",
    [dict(spp=0), dict(spp=1.5), dict(width=-3), dict(height=10**9), dict(method="mlt"),
     dict(noise=2.0), dict(threads=0), dict(threads=100000), dict(max_memory="lots"),
     dict(progress="yes")],
)
def test_bad_arguments_are_value_errors(kwargs):
    scene = pm.load_file(SCENES / "cornell-caustics.toml", width=16, height=12)
    with pytest.raises(ValueError):
        pm.render(scene, **kwargs)


def test_bad_load_file_overrides_are_refused_at_load():
    with pytest.raises(ValueError, match="spp"):
        pm.load_file(SCENES / "cornell-caustics.toml", spp=-1)


def test_a_still_is_not_a_sequence_nor_a_sequence_a_still():
    still = pm.load_file(SCENES / "cornell-caustics.toml", width=16, height=12)
    with pytest.raises(ValueError, match="animation"):
        pm.render_sequence(still)
    anim = pm.load_file(SCENES / "anim-ball.toml", width=16, height=12)
    with pytest.raises(ValueError, match="render_sequence"):
        pm.render(anim)
    with pytest.raises(ValueError, match="frames"):
        pm.render_sequence(anim, frames=[0, 2])
    with pytest.raises(ValueError, match="frames"):
        pm.render_sequence(anim, frames=range(0, 10**6))


def test_a_progress_callback_that_raises_stops_the_render_with_its_exception():
    scene = pm.load_file(SCENES / "cornell-caustics.toml", width=64, height=48)

    def fail(_):
        raise RuntimeError("from the callback")

    with pytest.raises(RuntimeError, match="from the callback"):
        pm.render(scene, spp=4, progress=fail)


def test_writing_over_the_scene_file_is_refused(tmp_path):
    r = pm.render(pm.load_file(SCENES / "cornell-caustics.toml", width=16, height=12), spp=1)
    with pytest.raises(ValueError, match="png"):
        r.write(tmp_path / "a.exr", png=tmp_path / "a.jpg")
    with pytest.raises(ValueError):
        r.write(tmp_path / "a.exr", stats=SCENES / "cornell-caustics.toml")
    assert not (tmp_path / "a.exr").exists()
