"""Shared fixtures: the repository's paths, the command-line binary, small renders of shipped scenes."""

import os
import subprocess
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]
SCENES = REPO / "scenes"
BIN = Path(os.environ.get("PMRENDER_BIN", REPO / "target" / "release" / "pmrender"))


def cli(*args: str) -> subprocess.CompletedProcess:
    """Runs the command-line renderer; fails the test on a non-zero exit."""
    r = subprocess.run([str(BIN), *args], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    return r


@pytest.fixture(scope="session")
def repo() -> Path:
    return REPO


@pytest.fixture(scope="session")
def scenes() -> Path:
    return SCENES
