"""Progressive renders from the module: the CLI's pixels for ``passes``, a kept ``time`` budget, and
the refusals a progressive render makes."""

import numpy as np
import pytest

import pmrender as pm
from conftest import SCENES, cli

SMALL = dict(width=64, height=48)


@pytest.mark.parametrize("method", ["pm", "path"])
def test_passes_are_the_clis(tmp_path, method):
    scene = SCENES / "cornell-caustics.toml"
    exr = tmp_path / "cli.exr"
    cli("render", str(scene), "-o", str(exr), "--method", method, "--passes", "2", "--spp", "4",
        "--width", "64", "--height", "48", "--quiet")
    r = pm.render(pm.load_file(scene, **SMALL), method=method, spp=4, passes=2)
    assert np.array_equal(r.image, pm.read_image(exr))
    assert r.stats["progressive"]["passes"] == 2
    assert r.stats["progressive"]["stopped"] == "passes"


def test_a_time_budget_is_kept():
    # One pass here takes about 1 s on 2 cores (its photons are most of it): a budget of 4 s leaves
    # room for more than one whatever the machine's speed, and the end must stay within 10 % of it.
    r = pm.render(pm.load_file(SCENES / "cornell-caustics.toml", **SMALL), spp=4, time=4.0)
    p = r.stats["progressive"]
    assert p["stopped"] == "time" and p["passes"] >= 2
    assert r.stats["time"]["total_s"] <= 4.4


def test_what_a_progressive_render_cannot_do_is_refused():
    scene = pm.load_file(SCENES / "cornell-caustics.toml", **SMALL)
    with pytest.raises(ValueError, match="passes"):
        pm.render(scene, passes=0)
    with pytest.raises(ValueError, match="time"):
        pm.render(scene, time=-1.0)
    with pytest.raises(ValueError, match="bake"):
        pm.render(scene, spp=4, passes=2, bake=pm.bake(scene, spp=4))
    with pytest.raises(ValueError, match="--passes"):
        pm.render(scene, spp=4, passes=2, tiles=2)
