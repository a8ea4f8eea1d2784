"""The convergence study from Python: the converge command's table."""

import json
import math

import pmrender as pm
from conftest import SCENES, cli


def test_converge_rows_are_the_commands(tmp_path):
    scene = SCENES / "cornell-caustics.toml"
    ref = tmp_path / "ref.exr"
    cli("render", str(scene), "-o", str(ref), "--width", "48", "--height", "36", "--spp", "16",
        "--method", "pm-fg", "--quiet")
    cli("converge", str(scene), "--photons", "2e3,2e4", "--reference", str(ref),
        "-o", str(tmp_path / "cli"), "--spp", "2", "--quiet")
    rows = pm.converge(pm.load_file(scene), photons=[2e3, 2e4], reference=ref, spp=2)
    assert [r["photons"] for r in rows] == [2000, 20000]
    assert all(math.isfinite(r["beauty"]) and r["beauty"] > 0 for r in rows)
    table = json.loads((tmp_path / "cli" / "converge.json").read_text())
    cli_rows = table["rows"] if isinstance(table, dict) else table
    for mine, theirs in zip(rows, cli_rows):
        assert mine["beauty"] == theirs["beauty"]
    assert not (tmp_path / "py").exists()
    pm.converge(pm.load_file(scene), photons=[2e3], reference=ref, spp=2, out=tmp_path / "py")
    assert (tmp_path / "py" / "converge.json").exists()
