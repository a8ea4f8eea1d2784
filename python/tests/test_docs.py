"""The scripts docs/python.md shows run as they are written."""

import subprocess
import sys

import pytest

from conftest import REPO


@pytest.mark.parametrize("script", ["convergence.py", "cache_report.py"])
def test_the_documented_script_runs(tmp_path, script):
    r = subprocess.run([sys.executable, str(REPO / "docs" / "python" / script), str(tmp_path)],
                       cwd=REPO, capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    assert list(tmp_path.glob("*.png")), r.stdout
