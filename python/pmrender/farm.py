"""pmrender on many machines with Dask: a sequence's chunks of frames, or a still's tiles shaded apart
from one bake, as Dask tasks; the same pixels as one machine.

    pmrender-farm SCENE.toml -o out/walk-####.exr [--png out/walk-####.png] [--stats out/summary.json]
                  [--frames A..B] [--chunk N | --shared-bake] (--workers N | --scheduler tcp://HOST:PORT)
                  [--tiles N]

Every kind of job is defined by the renderer itself, so that the farm's images are by construction
the command line's: a chunk of a sequence is ``pmrender render --chunk N`` (the temporal cache starts
afresh every N frames; a chunk renders from its first frame), a tiled still is ``pmrender render
--tiles N`` (one bake of the photon maps and pass A over the whole image, each band of rows shaded
apart from it), a camera walk's frame is ``pmrender render --shared-bake`` (one bake of the whole
walk: photon maps traced once, one cache filled over every frame's view; each frame, or each tile of
a frame with ``--tiles``, shaded from it alone). The bake is a task of its own; Dask ships its bytes to the workers that shade the
tiles. Workers return pixels; this process (the client) writes every output atomically, so a worker
lost mid-task leaves nothing behind and Dask runs its task again elsewhere. A second run skips the
frames whose outputs all exist.
"""

from __future__ import annotations

import argparse
import functools
import json
import os
import re
import sys
import time
from pathlib import Path
from typing import Dict, List, Optional, Sequence, Tuple

import pmrender as pm

__all__ = ["render", "main"]


# ----------------------------------------------------------------------------------------------
# Tasks: run on the workers; module-level functions, so that they pickle by name.


@functools.lru_cache(maxsize=8)
def _scene(path: str, stamp: Tuple[int, int], settings: Tuple[Tuple[str, object], ...]) -> pm.Scene:
    """A worker's scene, loaded once per file version and settings."""
    return pm.load_file(path, **dict(settings))


def _load(job: dict) -> pm.Scene:
    st = os.stat(job["scene"])
    return _scene(job["scene"], (st.st_mtime_ns, st.st_size), tuple(sorted(job["settings"].items())))


def _worker_name() -> str:
    try:
        from distributed import get_worker

        return get_worker().address
    except (ImportError, ValueError):
        return "local"


def _layers(r: "pm.Result", rows: Optional[Tuple[int, int]] = None) -> dict:
    """A result's pixels as bytes (the rows ``rows`` only, for a tile), and its statistics."""
    sl = slice(None) if rows is None else slice(rows[0], rows[1])
    return {
        "beauty": r.image[sl].tobytes(),
        "layers": [(name, img[sl].tobytes()) for name, img in r.layers.items()],
        "stats": r.stats,
    }


def bake_task(job: dict) -> dict:
    """The bake a tiled still's tiles shade from: its file's bytes."""
    t = time.monotonic()
    b = pm.bake(_load(job), threads=job["threads"])
    data = b.to_bytes()
    phases = b.stats["time"]
    return {"bake": data, "time_s": time.monotonic() - t, "worker": _worker_name(), "bytes": len(data),
            "trace_s": phases.get("trace_photons_s"), "fill_s": phases.get("fill_cache_s")}


def tile_task(job: dict, baked: dict, window: Tuple[int, int, int, int]) -> dict:
    """One band of rows of a tiled still, shaded from the bake."""
    t = time.monotonic()
    scene = _load(job)
    bake = pm.Bake.from_bytes(baked["bake"])
    r = pm.render(scene, threads=job["threads"], bake=bake, crop=tuple(window))
    out = _layers(r, (window[1], window[3]))
    out.update(window=tuple(window), width=r.width, height=r.height,
               time_s=time.monotonic() - t, worker=_worker_name())
    return out


def walk_frame_task(job: dict, baked: dict, frame: int,
                    window: Optional[Tuple[int, int, int, int]] = None) -> dict:
    """One frame of a walk (or the band of rows ``window`` of it), shaded from the walk's bake."""
    t = time.monotonic()
    scene = _load(job)
    bake = pm.Bake.from_bytes(baked["bake"])
    crop = None if window is None else tuple(window)
    r = pm.render(scene, threads=job["threads"], bake=bake, frame=frame, crop=crop)
    out = _layers(r, None if window is None else (window[1], window[3]))
    out.update(frame=frame, window=crop, width=r.width, height=r.height,
               time_s=time.monotonic() - t, worker=_worker_name())
    return out


def still_task(job: dict) -> dict:
    """A still in one piece (no tiles): the command line's render."""
    t = time.monotonic()
    r = pm.render(_load(job), threads=job["threads"])
    out = _layers(r)
    out.update(width=r.width, height=r.height, time_s=time.monotonic() - t, worker=_worker_name())
    return out


def chunk_task(job: dict, first: int, last: int) -> dict:
    """Frames ``first..last`` of one chunk (rendered from the chunk's start, as the command line does)."""
    t = time.monotonic()
    frames = []
    for f, r in pm.render_sequence(_load(job), frames=range(first, last + 1), chunk=job["chunk"],
                                   threads=job["threads"]):
        out = _layers(r)
        out.update(frame=f, width=r.width, height=r.height)
        frames.append(out)
    return {"frames": frames, "first": first, "last": last, "time_s": time.monotonic() - t,
            "worker": _worker_name()}


def _suspicious(keys, dask_scheduler=None) -> int:
    """On the scheduler: how many times the tasks ``keys`` were lost with a worker and run again."""
    return sum(dask_scheduler.tasks[k].suspicious for k in keys if k in dask_scheduler.tasks)


# ----------------------------------------------------------------------------------------------
# The client: the job's plan, outputs, progress, resume and summary.


class FarmError(ValueError):
    """A job the farm refuses (bad options), said before any task is sent."""


def _pattern(opt: str, path: Optional[str], animated: bool):
    """A frame number → output path function (the command line's run of ``#``), or None."""
    if path is None:
        return None
    runs = re.findall(r"#+", path)
    if not animated:
        if runs:
            raise FarmError(f"{opt}: '{path}' holds # but the scene is not animated")
        return lambda f: path
    if len(runs) != 1:
        raise FarmError(f"{opt}: '{path}' must hold one run of # for the frame number (e.g. "
                        "walk-####.exr): the scene is animated")
    if len(runs[0]) > 10:
        raise FarmError(f"{opt}: '{path}' has a run of {len(runs[0])} #: a frame number takes at most 10")
    head, tail = path.split(runs[0], 1)
    return lambda f: f"{head}{f:0{len(runs[0])}d}{tail}"


def _frames(arg: Optional[str], n: int) -> Tuple[int, int]:
    if arg is None:
        return 0, n - 1
    m = re.fullmatch(r"\s*(\d+)\s*(?:\.\.=?\s*(\d+)\s*)?", arg)
    a, b = (int(m.group(1)), int(m.group(2) or m.group(1))) if m else (1, 0)
    if a > b or b >= n:
        raise FarmError(f"--frames: '{arg}' is not a range A..B of frames within 0..{n - 1} (inclusive)")
    return a, b


class _Bar:
    """One line on stderr: tasks done of all, frames or tiles written, the time left."""

    def __init__(self, total: int, what: str, quiet: bool):
        # As the command line's bar: not drawn into a file or a pipe.
        self.total, self.what, self.quiet = total, what, quiet or not sys.stderr.isatty()
        self.start = time.monotonic()
        self.done = 0

    def step(self, n: int = 1):
        self.done += n
        if self.quiet:
            return
        elapsed = time.monotonic() - self.start
        eta = elapsed / self.done * (self.total - self.done) if self.done else 0.0
        filled = int(30 * self.done / max(self.total, 1))
        sys.stderr.write(f"\rpmrender-farm [{'=' * filled}{' ' * (30 - filled)}] "
                         f"{self.done}/{self.total} {self.what}  {elapsed:5.0f} s  eta {eta:4.0f} s")
        if self.done >= self.total:
            sys.stderr.write("\n")
        sys.stderr.flush()


def _nbytes(part: dict) -> int:
    """The pixel bytes a result brought back."""
    return len(part["beauty"]) + sum(len(b) for _, b in part["layers"])


def _write(path: str, png: Optional[str], width: int, height: int, part: dict):
    Path(path).parent.mkdir(parents=True, exist_ok=True)
    if png:
        Path(png).parent.mkdir(parents=True, exist_ok=True)
    pm._native.write_exr(path, width, height, part["beauty"], part["layers"], png)


def _paste(canvas: Dict[str, bytearray], tile: dict):
    """A tile's rows copied into the full image's buffers."""
    row = tile["width"] * 12
    at = tile["window"][1] * row
    for name, data in [("beauty", tile["beauty"])] + list(tile["layers"]):
        buf = canvas.setdefault(name, bytearray(tile["height"] * row))
        buf[at:at + len(data)] = data


def _walk(client, job: dict, local: "pm.Scene", patterns, frames: Tuple[int, int],
          tiles: Optional[int], futures: list, summary: dict, quiet: bool):
    """A shared-bake walk: the bake task, then a task per frame (or per tile of each frame) depending
    on it; each frame written here once all its pixels are back."""
    from distributed import as_completed

    at_exr, at_png = patterns
    first, last = frames
    outputs = lambda f: [p for p in (at_exr(f), at_png(f) if at_png else None) if p]
    todo = [f for f in range(first, last + 1) if not all(os.path.exists(p) for p in outputs(f))]
    summary["frames_skipped"] = last - first + 1 - len(todo)
    if not todo:
        return
    width, height = local.size
    windows = pm.tile_windows(width, height, tiles) if tiles is not None else [None]
    bar = _Bar(len(todo) * len(windows) + 1, "tasks", quiet)
    baked = client.submit(bake_task, job, pure=False, retries=2)
    futures.append(baked)
    futures += [client.submit(walk_frame_task, job, baked, f, w, pure=False, retries=2)
                for f in todo for w in windows]
    canvases: Dict[int, Dict[str, bytearray]] = {}
    left = {f: len(windows) for f in todo}
    for fut in as_completed(futures):
        res = fut.result()
        bar.step()
        if "bake" in res:
            summary["bake_s"], summary["bake_bytes"] = res["time_s"], res["bytes"]
            summary["tasks"].append({"kind": "bake", "time_s": res["time_s"], "trace_s": res["trace_s"],
                                     "fill_s": res["fill_s"], "worker": res["worker"]})
            continue
        f = res["frame"]
        summary["tasks"].append({"kind": "frame" if res["window"] is None else "tile", "frame": f,
                                 "window": None if res["window"] is None else list(res["window"]),
                                 "time_s": res["time_s"], "worker": res["worker"],
                                 "result_bytes": _nbytes(res)})
        if res["window"] is None:
            part = res
        else:
            _paste(canvases.setdefault(f, {}), res)
            left[f] -= 1
            if left[f]:
                continue
            canvas = canvases.pop(f)
            names = [n for n, _ in res["layers"]]
            part = {"beauty": bytes(canvas["beauty"]), "layers": [(n, bytes(canvas[n])) for n in names]}
        _write(at_exr(f), at_png(f) if at_png else None, res["width"], res["height"], part)
        summary["frames_written"] += 1
        summary["frames"].append({"frame": f, "worker": res["worker"], "stats": res["stats"]})


def render(
    scene: str,
    *,
    client,
    output: str,
    png: Optional[str] = None,
    stats: Optional[str] = None,
    frames: Optional[str] = None,
    chunk: Optional[int] = None,
    tiles: Optional[int] = None,
    threads: Optional[int] = None,
    settings: Optional[dict] = None,
    quiet: bool = False,
    shared_bake: bool = False,
) -> dict:
    """Renders ``scene`` (a path) on the Dask ``client``'s workers and writes its outputs here.

    ``output`` / ``png``: paths, with a run of ``#`` for the frame number of an animated scene;
    ``frames``: ``"A..B"``; ``chunk``: a sequence's chunk length (default: the whole sequence, one
    task); ``shared_bake``: a camera walk baked once, then a task per frame (``pmrender render
    --shared-bake``); ``tiles``: the bands of a still, or of each frame of a shared-bake walk
    (default: one task, the plain render); ``threads``:
    each task's worker threads (default: all of its machine's); ``settings``: ``load_file``'s
    overrides (``width``, ``spp``, ...). Returns the summary (also written to ``stats``): the tasks,
    their times and workers, the frames written and skipped. A bad scene or option raises before any
    task is sent.
    """
    t0 = time.monotonic()
    settings = dict(settings or {})
    path = os.path.abspath(os.fspath(scene))
    local = pm.load_file(path, **settings)  # a bad scene is refused here, before any task
    animated = local.frames is not None
    at_exr, at_png = _pattern("-o", output, animated), _pattern("--png", png, animated)
    if not output.lower().endswith(".exr"):
        raise FarmError(f"-o: '{output}' must end in .exr")
    if png is not None and not png.lower().endswith(".png"):
        raise FarmError(f"--png: '{png}' must end in .png")
    for opt, v in (("--chunk", chunk), ("--tiles", tiles), ("--threads", threads)):
        if v is not None and v < 1:
            raise FarmError(f"{opt}: {v} must be at least 1")
    if animated and tiles is not None and not shared_bake:
        raise FarmError("--tiles: shades a sequence's frames from a bake they share: add --shared-bake")
    if shared_bake and not animated:
        raise FarmError("--shared-bake: the scene has no [animation]")
    if shared_bake and chunk is not None:
        raise FarmError("--shared-bake: shades every frame apart from one bake: leave out --chunk")
    if not animated and (frames is not None or chunk is not None):
        raise FarmError(f"{'--frames' if frames is not None else '--chunk'}: the scene has no [animation]")
    job = {"scene": path, "settings": settings, "threads": threads,
           "chunk": chunk if chunk is not None else local.frames}
    summary = {"scene": path, "workers": len(client.scheduler_info()["workers"]), "tasks": [],
               "frames": [], "frames_written": 0, "frames_skipped": 0, "bake_s": None,
               "bake_bytes": None}
    from distributed import as_completed

    futures = []
    try:
        if shared_bake:
            _walk(client, job, local, (at_exr, at_png), _frames(frames, local.frames), tiles,
                  futures, summary, quiet)
        elif animated:
            first, last = _frames(frames, local.frames)
            outputs = lambda f: [p for p in (at_exr(f), at_png(f) if at_png else None) if p]
            todo = [f for f in range(first, last + 1) if not all(os.path.exists(p) for p in outputs(f))]
            summary["frames_skipped"] = last - first + 1 - len(todo)
            chunks = sorted({(f - f % job["chunk"]) for f in todo})
            bar = _Bar(len(todo), "frames", quiet)
            for c in chunks:
                a, b = max(c, first), min(c + job["chunk"] - 1, last)
                futures.append(client.submit(chunk_task, job, a, b, pure=False, retries=2))
            for fut in as_completed(futures):
                res = fut.result()
                summary["tasks"].append({"kind": "chunk", "frames": [res["first"], res["last"]],
                                         "time_s": res["time_s"], "worker": res["worker"],
                                         "result_bytes": sum(_nbytes(f) for f in res["frames"])})
                for fr in res["frames"]:
                    if fr["frame"] in todo:
                        _write(at_exr(fr["frame"]), at_png(fr["frame"]) if at_png else None,
                               fr["width"], fr["height"], fr)
                        summary["frames_written"] += 1
                        summary["frames"].append({"frame": fr["frame"], "worker": res["worker"],
                                                  "stats": fr["stats"]})
                        bar.step()
        elif os.path.exists(output) and (png is None or os.path.exists(png)):
            summary["frames_skipped"] = 1
        elif tiles is None:
            bar = _Bar(1, "tasks", quiet)
            futures.append(client.submit(still_task, job, pure=False, retries=2))
            res = futures[0].result()
            summary["tasks"].append({"kind": "still", "time_s": res["time_s"], "worker": res["worker"],
                                     "result_bytes": _nbytes(res)})
            _write(output, png, res["width"], res["height"], res)
            summary["frames_written"] = 1
            summary["frames"].append({"frame": None, "worker": res["worker"], "stats": res["stats"]})
            bar.step()
        else:
            width, height = local.size
            windows = pm.tile_windows(width, height, tiles)
            bar = _Bar(len(windows) + 1, "tasks", quiet)
            baked = client.submit(bake_task, job, pure=False, retries=2)
            futures.append(baked)
            futures += [client.submit(tile_task, job, baked, w, pure=False, retries=2) for w in windows]
            canvas: Dict[str, bytearray] = {}
            names: List[str] = []
            for fut in as_completed(futures):
                res = fut.result()
                bar.step()
                if "bake" in res:
                    summary["bake_s"], summary["bake_bytes"] = res["time_s"], res["bytes"]
                    summary["tasks"].append({"kind": "bake", "time_s": res["time_s"],
                                             "trace_s": res["trace_s"], "fill_s": res["fill_s"],
                                             "worker": res["worker"]})
                    continue
                names = [n for n, _ in res["layers"]]
                _paste(canvas, res)
                summary["tasks"].append({"kind": "tile", "window": list(res["window"]),
                                         "time_s": res["time_s"], "worker": res["worker"],
                                         "result_bytes": _nbytes(res), "stats": res["stats"]})
            full = {"beauty": bytes(canvas["beauty"]), "layers": [(n, bytes(canvas[n])) for n in names]}
            _write(output, png, width, height, full)
            summary["frames_written"] = 1
    except BaseException:
        client.cancel(futures)
        raise
    try:
        summary["retries"] = client.run_on_scheduler(_suspicious, [f.key for f in futures])
    except Exception:  # a scheduler without pmrender installed cannot count them
        summary["retries"] = None
    summary["wall_s"] = time.monotonic() - t0
    if stats:
        Path(stats).parent.mkdir(parents=True, exist_ok=True)
        tmp = f"{stats}.tmp"
        with open(tmp, "w") as fh:
            json.dump(summary, fh, indent=2)
        os.replace(tmp, stats)
    return summary


def main(argv: Optional[Sequence[str]] = None) -> int:
    """The ``pmrender-farm`` command: exit 0 done, 2 bad input (nothing sent), 130 Ctrl-C."""
    p = argparse.ArgumentParser(prog="pmrender-farm", description=__doc__.split("\n\n")[0])
    p.add_argument("scene")
    p.add_argument("-o", "--output", required=True)
    p.add_argument("--png")
    p.add_argument("--stats", help="the job's summary JSON: tasks, times, workers, frames")
    p.add_argument("--frames", help="A..B inclusive (default: all)")
    p.add_argument("--chunk", type=int, help="frames per task; the temporal cache starts afresh at each "
                   "chunk, as with `pmrender render --chunk N` (default: the whole sequence)")
    p.add_argument("--shared-bake", action="store_true", help="a camera walk baked once (photon maps "
                   "and one cache over every frame's view), then a task per frame, as with `pmrender "
                   "render --shared-bake`")
    p.add_argument("--tiles", type=int, help="a still's bands of rows (or each frame's, with "
                   "--shared-bake), shaded apart from one bake, as with `pmrender render --tiles N` "
                   "(default: one task)")
    who = p.add_mutually_exclusive_group(required=True)
    who.add_argument("--workers", type=int, help="start a local cluster of N worker processes")
    who.add_argument("--scheduler", help="use a running scheduler, e.g. tcp://HOST:8786")
    p.add_argument("--threads", type=int, help="threads of each task (default: each worker's cores; "
                   "with --workers, this machine's cores shared out)")
    for name in ("width", "height", "spp", "seed"):
        p.add_argument(f"--{name}", type=int)
    p.add_argument("--method")
    p.add_argument("--noise", type=float)
    p.add_argument("--quiet", action="store_true")
    a = p.parse_args(argv)
    settings = {k: getattr(a, k) for k in ("width", "height", "spp", "seed", "method", "noise")
                if getattr(a, k) is not None}
    cluster = client = None
    try:
        from distributed import Client, LocalCluster

        # Every check that needs no worker first: a bad scene or option costs no cluster.
        local = pm.load_file(a.scene, **settings)
        threads = a.threads
        if a.workers is not None:
            if a.workers < 1:
                raise FarmError(f"--workers: {a.workers} must be at least 1")
            threads = threads or max(1, (os.cpu_count() or 1) // a.workers)
            cluster = LocalCluster(n_workers=a.workers, threads_per_worker=1, processes=True,
                                   dashboard_address=None)
            client = Client(cluster)
        else:
            client = Client(a.scheduler, timeout="20s")
        del local
        summary = render(a.scene, client=client, output=a.output, png=a.png, stats=a.stats,
                         frames=a.frames, chunk=a.chunk, tiles=a.tiles, threads=threads,
                         settings=settings, quiet=a.quiet, shared_bake=a.shared_bake)
        if not a.quiet:
            print(f"pmrender-farm: {summary['frames_written']} written, {summary['frames_skipped']} "
                  f"skipped (done before), {len(summary['tasks'])} tasks on {summary['workers']} "
                  f"workers in {summary['wall_s']:.1f} s", file=sys.stderr)
        return 0
    except (pm.SceneError, FarmError, ValueError) as e:
        print(f"pmrender-farm: {e}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("pmrender-farm: interrupted", file=sys.stderr)
        return 130
    except OSError as e:
        print(f"pmrender-farm: {e}", file=sys.stderr)
        return 1
    finally:
        if client is not None:
            client.close()
        if cluster is not None:
            cluster.close()


if __name__ == "__main__":
    sys.exit(main())
