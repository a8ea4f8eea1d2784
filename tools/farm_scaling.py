"""The farm's scaling: measured on this machine with 1 and 2 local workers, then simulated for 1–64
machines from the measured task times, the bake's size and a network model; the chart
docs/images/farm-scaling.png and the table printed (docs/farm.md).

    python tools/farm_scaling.py measure OUT.json [JOB]  # renders (minutes; nothing else running);
                                                        # JOB: only the jobs whose name holds it,
                                                        # merged into OUT.json
    python tools/farm_scaling.py simulate OUT.json    # the model and the chart

Model of N machines of this one's kind (2 cores each), one worker each: a still's bake runs on one
machine (photon trace + pass A; pass A and the tiles scale with the pixels); the bake's bytes reach
the other N − 1 workers one after another from the machine holding it (the worst case of Dask's
peer-to-peer transfer) over a 1 Gbit/s network with 0.5 ms per message; tasks go to the first free
worker in order (Dask's default for independent tasks of equal priority), each costing its measured
time with 2 threads plus the measured per-task overhead, and its pixels travel back to the client.
"""

import json
import subprocess
import sys
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
FARM = str(Path(sys.executable).parent / "pmrender-farm")
BIN = str(REPO / "target" / "release" / "pmrender")
BANDWIDTH = 125e6  # bytes/s: 1 Gbit/s
LATENCY = 0.5e-3   # s per message

JOBS = {
    "anim-ball (48 frames, 320×240, chunks of 8)": (
        "scenes/anim-ball.toml", ["--chunk", "8"], "frames"),
    "sibenik-walk (48 frames, 320×240, chunks of 8)": (
        "tests/scenes/sibenik-walk.toml", ["--chunk", "8", "--width", "320", "--height", "240"], "frames"),
    "sibenik-walk (48 frames, 320×240, shared bake)": (
        "tests/scenes/sibenik-walk.toml", ["--shared-bake", "--width", "320", "--height", "240"], "frames"),
    "cornell-caustics still 1024² (16 tiles)": (
        "scenes/cornell-caustics.toml", ["--tiles", "16", "--width", "1024", "--height", "1024"], "still"),
}


def run(cmd):
    t = time.monotonic()
    subprocess.run(cmd, check=True, capture_output=True)
    return time.monotonic() - t


def measure(out_json, only=None):
    out = Path(out_json)
    results = json.loads(out.read_text()) if only and out.exists() else {}
    for name, (scene, extra, kind) in JOBS.items():
        if only and only not in name:
            continue
        tmp = Path("/tmp/farm-scaling")
        subprocess.run(["rm", "-rf", str(tmp)])
        tmp.mkdir(parents=True)
        o = str(tmp / ("cli-####.exr" if kind == "frames" else "cli.exr"))
        row = {"cli_s": run([BIN, "render", str(REPO / scene), "-o", o, "--quiet", *extra])}
        for workers, threads in ((1, 2), (2, 1)):
            o = str(tmp / f"w{workers}" / ("f-####.exr" if kind == "frames" else "still.exr"))
            s = str(tmp / f"w{workers}.json")
            row[f"farm{workers}_s"] = run([FARM, str(REPO / scene), "-o", o, "--workers", str(workers),
                                           "--threads", str(threads), "--stats", s, "--quiet", *extra])
            # Each frame's statistics are not part of the model: the tasks are.
            summary = json.loads(Path(s).read_text())
            row[f"summary{workers}"] = {k: v for k, v in summary.items() if k != "frames"}
        results[name] = row
        print(name, {k: v for k, v in row.items() if k.endswith("_s")}, flush=True)
    Path(out_json).write_text(json.dumps(results, indent=1))


def startup(row, workers):
    """Seconds the command spends before and after its job: the cluster's start and stop, measured."""
    return row[f"farm{workers}_s"] - row[f"summary{workers}"]["wall_s"]


def model(s, n, start_s, tiles=None, pixel_scale=1.0):
    """Wall seconds of the job in summary ``s`` on ``n`` workers: ``start_s``, the bake (its pass A
    scaled by ``pixel_scale``) and its shipping, the tasks in order on the first free worker with
    the measured per-task overhead, the pixels back to the client. ``tiles``: that many tile tasks,
    their times drawn in turn from the measured ones (each the same number of pixels)."""
    tasks = [t for t in s["tasks"] if t["kind"] != "bake"]
    overhead = max(0.0, (s["wall_s"] - sum(t["time_s"] for t in s["tasks"])) / max(len(s["tasks"]), 1))
    ready = 0.0
    bake = [t for t in s["tasks"] if t["kind"] == "bake"]
    if bake:
        b = bake[0]
        trace = b.get("trace_s") or 0.0
        ready = trace + (b["time_s"] - trace) * pixel_scale
        ready += (n - 1) * (LATENCY + s["bake_bytes"] / BANDWIDTH)
    order = lambda t: (t.get("frame") or 0, (t.get("frames") or t.get("window") or [])[0:2])
    times = [t["time_s"] for t in sorted(tasks, key=order)]
    result_bytes = sum(t["result_bytes"] for t in tasks)
    if tiles is not None:
        times = [times[i % len(times)] for i in range(tiles)]
        result_bytes *= pixel_scale
    free = [ready] * n
    for t in times:
        i = min(range(n), key=lambda k: free[k])
        free[i] += t + overhead
    return start_s + max(free) + result_bytes / BANDWIDTH


def simulate(out_json):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    results = json.loads(Path(out_json).read_text())
    ns = [1, 2, 4, 8, 16, 32, 64]
    print("Measured here (2 cores) and the model of the same runs:\n")
    print("| job | CLI s | farm, 1 worker × 2 threads: measured / model s | "
          "2 workers × 1 thread: measured / model s |")
    print("|---|---:|---:|---:|")
    for name, row in results.items():
        m1 = model(row["summary1"], 1, startup(row, 1))
        m2 = model(row["summary2"], 2, startup(row, 2))
        print(f"| {name} | {row['cli_s']:.1f} | {row['farm1_s']:.1f} / {m1:.1f} | "
              f"{row['farm2_s']:.1f} / {m2:.1f} |")
    jobs = [(name, row, None, 1.0) for name, row in results.items()]
    still = results["cornell-caustics still 1024² (16 tiles)"]
    jobs.append(("cornell-caustics still 4096² (256 tiles)", still, 256, 16.0))
    print("\nSimulated on N machines of this kind (2 cores, one worker of 2 threads each), seconds:\n")
    print("| job | " + " | ".join(f"N = {n}" for n in ns) + " |")
    print("|---|" + "---:|" * len(ns))
    fig, ax = plt.subplots(figsize=(6, 4))
    for name, row, tiles, scale in jobs:
        times = [model(row["summary1"], n, startup(row, 1), tiles, scale) for n in ns]
        ax.plot(ns, [times[0] / t for t in times], "o-", label=name)
        print(f"| {name} | " + " | ".join(f"{t:.1f}" for t in times) + " |")
    ax.plot(ns, ns, ":", color="grey", label="linear")
    ax.set_xscale("log", base=2)
    ax.set_yscale("log", base=2)
    ax.set_xlabel("machines (2 cores each)")
    ax.set_ylabel("speed-up over one machine (simulated)")
    ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(REPO / "docs" / "images" / "farm-scaling.png", dpi=120)


if __name__ == "__main__":
    {"measure": measure, "simulate": simulate}[sys.argv[1]](*sys.argv[2:])
