"""The farm's scaling: measured on this machine with 1 and 2 local workers, then simulated for 1–64
machines from the measured task times, the bake's size and a network model; the chart
docs/images/farm-scaling.png and the table printed (docs/farm.md).

    python tools/farm_scaling.py measure OUT.json     # renders (minutes; nothing else running)
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
    "cornell-caustics still 1024² (16 tiles)": (
        "scenes/cornell-caustics.toml", ["--tiles", "16", "--width", "1024", "--height", "1024"], "still"),
}


def run(cmd):
    t = time.monotonic()
    subprocess.run(cmd, check=True, capture_output=True)
    return time.monotonic() - t


def measure(out_json):
    results = {}
    for name, (scene, extra, kind) in JOBS.items():
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
            row[f"summary{workers}"] = json.loads(Path(s).read_text())
        results[name] = row
        print(name, {k: v for k, v in row.items() if k.endswith("_s")}, flush=True)
    Path(out_json).write_text(json.dumps(results, indent=1))


def simulate_job(row, n, scale=1.0):
    """Wall time on n machines from the 1-worker run (2 threads per task); ``scale`` multiplies
    every per-pixel cost (pass A and the tiles), for a larger still."""
    s = row["summary1"]
    tasks = [t for t in s["tasks"] if t["kind"] != "bake"]
    overhead = max(0.0, (s["wall_s"] - sum(t["time_s"] for t in s["tasks"])) / max(len(s["tasks"]), 1))
    start = 0.0
    bake = [t for t in s["tasks"] if t["kind"] == "bake"]
    if bake:
        b = bake[0]
        trace = b.get("trace_s") or 0.0
        start = trace + (b["time_s"] - trace) * scale
        start += (n - 1) * (LATENCY + s["bake_bytes"] / BANDWIDTH)
    free = [start] * n
    for t in sorted(tasks, key=lambda t: t.get("frames", t.get("window", [0]))[0]):
        i = min(range(n), key=lambda k: free[k])
        free[i] += t["time_s"] * scale + overhead
    # The pixels come back to the client over its one link.
    pixel_bytes = sum(t["result_bytes"] for t in tasks) * scale
    return max(free) + pixel_bytes / BANDWIDTH


def simulate(out_json):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    results = json.loads(Path(out_json).read_text())
    ns = [1, 2, 4, 8, 16, 32, 64]
    fig, ax = plt.subplots(figsize=(6, 4))
    jobs = list(results.items())
    jobs.append(("cornell-caustics still 4096² (256 tiles, scaled ×16)",
                 results["cornell-caustics still 1024² (16 tiles)"]))
    print("| job | CLI s | farm 1 worker s | farm 2 workers s | simulated: " +
          " | ".join(f"{n}" for n in ns) + " |")
    for name, row in jobs:
        scale = 16.0 if "4096" in name else 1.0
        times = [simulate_job(row, n, scale) for n in ns]
        ax.plot(ns, [times[0] / t for t in times], "o-", label=name)
        if scale == 1.0:
            meas = f"{row['cli_s']:.1f} | {row['farm1_s']:.1f} | {row['farm2_s']:.1f}"
        else:
            meas = "— | — | —"
        print(f"| {name} | {meas} | " + " | ".join(f"{t:.1f}" for t in times) + " |")
    ax.plot(ns, ns, ":", color="grey", label="linear")
    ax.set_xscale("log", base=2)
    ax.set_yscale("log", base=2)
    ax.set_xlabel("machines (2 cores each)")
    ax.set_ylabel("speed-up over one machine (simulated)")
    ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(REPO / "docs" / "images" / "farm-scaling.png", dpi=120)


if __name__ == "__main__":
    {"measure": measure, "simulate": simulate}[sys.argv[1]](sys.argv[2])
