"""The farm on Dask: a local cluster and a real scheduler with worker processes give the command
line's images byte for byte; a killed worker loses nothing; a second run resumes; a bad scene fails
before any task."""

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from conftest import SCENES, cli

pytest.importorskip("distributed")

VENV_BIN = Path(sys.executable).parent
FARM = str(VENV_BIN / "pmrender-farm")
SMALL = ["--width", "48", "--height", "36", "--spp", "2"]


def farm(*args, check=True):
    r = subprocess.run([FARM, *args], capture_output=True, text=True, timeout=300)
    if check:
        assert r.returncode == 0, r.stderr
    return r


def same_files(a: Path, b: Path, names):
    for n in names:
        assert (a / n).read_bytes() == (b / n).read_bytes(), n


def test_a_local_cluster_renders_the_clis_frames_and_resumes(tmp_path):
    scene = str(SCENES / "anim-ball.toml")
    (tmp_path / "cli").mkdir()
    cli("render", scene, "-o", str(tmp_path / "cli" / "f-##.exr"), "--frames", "0..5", "--chunk", "3",
        *SMALL, "--quiet")
    summary = tmp_path / "farm" / "summary.json"
    farm(scene, "-o", str(tmp_path / "farm" / "f-##.exr"), "--frames", "0..5", "--chunk", "3",
         "--workers", "2", "--stats", str(summary), *SMALL)
    names = [f"f-{f:02}.exr" for f in range(6)]
    same_files(tmp_path / "cli", tmp_path / "farm", names)
    s = json.loads(summary.read_text())
    assert s["frames_written"] == 6 and s["workers"] == 2
    assert sorted(t["frames"] for t in s["tasks"]) == [[0, 2], [3, 5]]
    # Each frame's statistics, as the CLI's --stats gives them.
    assert sorted(f["frame"] for f in s["frames"]) == list(range(6))
    assert all(f["stats"]["frame"]["index"] == f["frame"] for f in s["frames"])
    # Resume: nothing to do, then only the frame that went missing.
    farm(scene, "-o", str(tmp_path / "farm" / "f-##.exr"), "--frames", "0..5", "--chunk", "3",
         "--workers", "2", "--stats", str(summary), *SMALL)
    again = json.loads(summary.read_text())
    assert again["frames_written"] == 0 and again["frames_skipped"] == 6
    (tmp_path / "farm" / "f-04.exr").unlink()
    farm(scene, "-o", str(tmp_path / "farm" / "f-##.exr"), "--frames", "0..5", "--chunk", "3",
         "--workers", "2", "--stats", str(summary), *SMALL)
    s = json.loads(summary.read_text())
    assert s["frames_written"] == 1 and s["frames_skipped"] == 5
    same_files(tmp_path / "cli", tmp_path / "farm", names)


@pytest.mark.parametrize("tiles", [None, "3"])
def test_a_still_on_a_local_cluster_is_the_clis(tmp_path, tiles):
    scene = str(SCENES / "blinds-room.toml")
    extra = ["--tiles", tiles] if tiles else []
    size = ["--width", "96", "--height", "72", "--spp", "4"]
    cli("render", scene, "-o", str(tmp_path / "cli.exr"), "--png", str(tmp_path / "cli.png"), *extra,
        *size, "--quiet")
    farm(scene, "-o", str(tmp_path / "farm.exr"), "--png", str(tmp_path / "farm.png"), "--workers", "2",
         *extra, *size)
    assert (tmp_path / "farm.exr").read_bytes() == (tmp_path / "cli.exr").read_bytes()
    assert (tmp_path / "farm.png").read_bytes() == (tmp_path / "cli.png").read_bytes()


def test_a_walk_baked_once_on_a_local_cluster_is_the_clis(tmp_path):
    scene = str(SCENES / "blinds-walk.toml")
    (tmp_path / "cli").mkdir()
    split = ["--frames", "4..7", "--shared-bake", "--tiles", "2"]
    cli("render", scene, "-o", str(tmp_path / "cli" / "f-##.exr"), *split, *SMALL, "--quiet")
    summary = tmp_path / "farm" / "summary.json"
    farm(scene, "-o", str(tmp_path / "farm" / "f-##.exr"), *split, "--workers", "2",
         "--stats", str(summary), *SMALL)
    same_files(tmp_path / "cli", tmp_path / "farm", [f"f-{f:02}.exr" for f in range(4, 8)])
    s = json.loads(summary.read_text())
    kinds = sorted(t["kind"] for t in s["tasks"])
    # One bake for the whole walk, then every frame's two tiles apart.
    assert kinds == ["bake"] + ["tile"] * 8 and s["frames_written"] == 4
    assert s["bake_bytes"] > 0 and sorted(f["frame"] for f in s["frames"]) == [4, 5, 6, 7]
    r = farm(scene, "-o", str(tmp_path / "farm2" / "f-##.exr"), "--tiles", "2", "--workers", "1",
             *SMALL, check=False)
    assert r.returncode == 2 and "--shared-bake" in r.stderr

def test_a_bad_scene_fails_before_any_task(tmp_path):
    bad = tmp_path / "bad.toml"
    bad.write_text('[camera]\neye = [0, 1, 3]\ntarget = [0, 1, 0]\nfov = "wide"\n')
    start = time.monotonic()
    r = farm(str(bad), "-o", str(tmp_path / "o.exr"), "--workers", "2", check=False)
    assert r.returncode == 2
    assert f"{bad}:4" in r.stderr and len(r.stderr.strip().splitlines()) == 1
    assert time.monotonic() - start < 10  # no cluster was started for it
    assert not (tmp_path / "o.exr").exists()
    r = farm(str(SCENES / "blinds-room.toml"), "-o", str(tmp_path / "o-##.exr"), "--workers", "1",
             check=False)
    assert r.returncode == 2 and "#" in r.stderr


KILLED = {
    # A sequence in chunks: each chunk a task.
    "chunks": ("anim-ball.toml", ["--frames", "0..7", "--chunk", "2", "--width", "96", "--height", "72",
                                  "--spp", "8"]),
    # A camera walk baked once: a bake task, then each frame's tiles as tasks.
    "shared bake": ("blinds-walk.toml", ["--frames", "0..7", "--shared-bake", "--tiles", "2",
                                         "--width", "96", "--height", "72", "--spp", "8"]),
}


@pytest.mark.parametrize("kind", list(KILLED))
def test_a_worker_killed_mid_run_loses_no_frame(tmp_path, kind):
    """A real scheduler and two worker processes; one is killed once the first frame is written."""
    dask = str(VENV_BIN / "dask")
    sched_file = tmp_path / "scheduler.json"
    env = dict(os.environ, DASK_DISTRIBUTED__WORKER__DAEMON="False")
    procs = [subprocess.Popen([dask, "scheduler", "--scheduler-file", str(sched_file), "--port", "0",
                               "--dashboard-address", ":0"], stdout=subprocess.DEVNULL,
                              stderr=subprocess.DEVNULL, env=env)]
    try:
        for _ in range(100):
            if sched_file.exists() and sched_file.read_text().strip():
                break
            time.sleep(0.1)
        address = json.loads(sched_file.read_text())["address"]
        workers = [subprocess.Popen([dask, "worker", address, "--nthreads", "1", "--nworkers", "1",
                                     "--no-nanny", "--dashboard-address", ":0"],
                                    stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, env=env)
                   for _ in range(2)]
        procs += workers
        name, args = KILLED[kind]
        scene = str(SCENES / name)
        job = subprocess.Popen([FARM, scene, "-o", str(tmp_path / "farm" / "f-##.exr"), "--scheduler",
                                address, "--threads", "1", "--stats", str(tmp_path / "s.json"), *args],
                               stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        deadline = time.monotonic() + 120
        while not list((tmp_path / "farm").glob("f-*.exr")) and time.monotonic() < deadline:
            time.sleep(0.05)
        workers[1].send_signal(signal.SIGKILL)
        _, err = job.communicate(timeout=300)
        assert job.returncode == 0, err
        (tmp_path / "cli").mkdir()
        cli("render", scene, "-o", str(tmp_path / "cli" / "f-##.exr"), *args, "--quiet")
        same_files(tmp_path / "cli", tmp_path / "farm", [f"f-{f:02}.exr" for f in range(8)])
        assert not [p for p in (tmp_path / "farm").iterdir() if not p.name.endswith(".exr")]
        assert json.loads((tmp_path / "s.json").read_text())["retries"] >= 0
    finally:
        for p in procs:
            p.kill()
            p.wait()
