"""pmrender from Python: scenes, renders, bakes, sequences and convergence tests as numpy arrays.

    import pmrender as pm

    scene = pm.load_file("scenes/cornell-caustics.toml", width=320, height=240)
    r = pm.render(scene, method="pm", spp=64)
    r.image                      # float32 H×W×3, linear: the pixels the CLI writes to its EXR
    r.layers["caustic"]          # each term of Jensen's split
    r.stats["cache"]["records"]  # the `--stats` JSON as a dictionary
    r.write("out.exr", png="out.png")

Renders release the GIL and run on their own threads; progress is delivered on the calling thread;
Ctrl-C stops a render within a second (KeyboardInterrupt). The same scene and seed give the same
pixels whatever the thread count, and the same as the `pmrender` command line.
"""

from __future__ import annotations

import json
import os
import sys
import warnings as _warnings
from typing import Callable, Dict, Iterator, List, Optional, Sequence, Tuple, Union

import numpy as np

from . import _native
from ._native import SceneError

__all__ = [
    "SceneError",
    "RenderWarning",
    "Scene",
    "Result",
    "Bake",
    "load_file",
    "render",
    "bake",
    "load_bake",
    "render_sequence",
    "converge",
    "read_image",
    "tile_windows",
]

Scene = _native.Scene


class RenderWarning(UserWarning):
    """A render succeeded on legal input but is likely not what was meant (the CLI's warnings: an
    asset's undefined material, a photon pass that stored nothing, ...)."""


def _warn(native) -> None:
    for w in native.warnings():
        _warnings.warn(w, RenderWarning, stacklevel=3)
PathLike = Union[str, "os.PathLike[str]"]
Progress = Union[None, bool, Callable[[float], object]]


def _pixels(buf: bytearray, width: int, height: int) -> np.ndarray:
    return np.frombuffer(buf, dtype="<f4").reshape(height, width, 3)


class Result:
    """A finished render: ``image`` (H×W×3 float32), ``layers`` (name → H×W×3), ``stats`` (dict)."""

    def __init__(self, native: "_native.RenderResult"):
        self._native = native
        self._image: Optional[np.ndarray] = None
        self._layers: Optional[Dict[str, np.ndarray]] = None
        self._stats: Optional[dict] = None

    @property
    def width(self) -> int:
        return self._native.width

    @property
    def height(self) -> int:
        return self._native.height

    @property
    def image(self) -> np.ndarray:
        """The beauty, linear float32 H×W×3: the values the CLI writes to the EXR's R, G, B."""
        if self._image is None:
            self._image = _pixels(self._native.image_bytes(), self.width, self.height)
        return self._image

    @property
    def layers(self) -> Dict[str, np.ndarray]:
        """Each term of the split (``emission``, ``direct``, ``caustic``, ``indirect``, ...) as the
        EXR's layers hold them; empty for ``path``."""
        if self._layers is None:
            self._layers = {
                name: _pixels(self._native.layer_bytes(name), self.width, self.height)
                for name in self._native.layer_names()
            }
        return self._layers

    @property
    def warnings(self) -> List[str]:
        """What the CLI would print as warnings for this render (also raised as ``RenderWarning``)."""
        return self._native.warnings()

    @property
    def stats(self) -> dict:
        """The statistics: the same structure and values as the CLI's ``--stats`` JSON."""
        if self._stats is None:
            self._stats = json.loads(self._native.stats_json())
        return self._stats

    def write(
        self,
        path: PathLike,
        png: Optional[PathLike] = None,
        stats: Optional[PathLike] = None,
        save_cache: Optional[PathLike] = None,
        cache_image: Optional[PathLike] = None,
    ) -> None:
        """Writes the CLI's outputs: the layered EXR at ``path`` and each other one given (all or
        none of them)."""
        self._native.write(
            os.fspath(path),
            png=_opt_path(png),
            stats=_opt_path(stats),
            save_cache=_opt_path(save_cache),
            cache_image=_opt_path(cache_image),
        )

    def __repr__(self) -> str:
        return f"<pmrender.Result {self.width}×{self.height}, layers {list(self.layers)}>"


class Bake:
    """The photon maps and caches of a render (``bake()``), to shade from many times
    (``render(scene, bake=b)``: pass B only, the same pixels) and to save (``load_bake``)."""

    def __init__(self, native: "_native.Bake"):
        self._native = native

    @property
    def method(self) -> str:
        return self._native.method

    @property
    def stats(self) -> Optional[dict]:
        """What making the bake did (``--stats`` structure); None for a bake loaded from a file."""
        text = self._native.stats_json()
        return None if text is None else json.loads(text)

    def save(self, path: PathLike) -> None:
        """Writes the bake as one file (through a temporary file renamed into place)."""
        self._native.save(os.fspath(path))

    def to_bytes(self) -> bytes:
        """The bake's file as bytes: what ``save`` writes, and what pickling a bake ships."""
        return self._native.to_bytes()

    @staticmethod
    def from_bytes(data: bytes) -> "Bake":
        """A bake from ``to_bytes``'s bytes (checked: a damaged one raises ValueError)."""
        return Bake(_native.bake_from_bytes(data))

    def __reduce__(self):
        return (Bake.from_bytes, (self.to_bytes(),))

    def __repr__(self) -> str:
        return f"<pmrender.Bake for method {self.method}>"


def _opt_path(p: Optional[PathLike]) -> Optional[str]:
    return None if p is None else os.fspath(p)


def _progress(progress: Progress) -> Optional[Callable[[float], object]]:
    """``True``: a bar on stderr; a callable: itself; ``None``/``False``: nothing."""
    if progress is None or progress is False:
        return None
    if progress is True:
        def bar(fraction: float) -> None:
            filled = int(fraction * 40)
            sys.stderr.write(f"\rpmrender [{'=' * filled}{' ' * (40 - filled)}] {fraction:4.0%}")
            if fraction >= 1.0:
                sys.stderr.write("\n")
            sys.stderr.flush()
        return bar
    if not callable(progress):
        raise ValueError("progress: must be None, True or a callable taking a fraction")
    return progress


def _int(name: str, v: Optional[float]) -> Optional[int]:
    """Whole numbers given as floats (1e5) are accepted; fractions are refused."""
    if v is None:
        return None
    if isinstance(v, bool) or not float(v).is_integer():
        raise ValueError(f"{name}: {v!r} is not a whole number")
    return int(v)


def load_file(
    path: PathLike,
    *,
    method: Optional[str] = None,
    spp: Optional[int] = None,
    noise: Optional[float] = None,
    aa_spp: Optional[int] = None,
    width: Optional[int] = None,
    height: Optional[int] = None,
    seed: Optional[int] = None,
    crop: Optional[Tuple[int, int, int, int]] = None,
    max_memory: Optional[str] = None,
) -> Scene:
    """Loads a scene file (TOML); the keywords are the CLI's overrides (``--width``, ``--spp``, ...),
    kept for every render of the scene. A bad file raises ``SceneError`` (``.path``, ``.line``)."""
    return _native.load_file(
        os.fspath(path),
        method=method,
        spp=_int("spp", spp),
        noise=noise,
        aa_spp=_int("aa_spp", aa_spp),
        width=_int("width", width),
        height=_int("height", height),
        seed=_int("seed", seed),
        crop=crop,
        max_memory=max_memory,
    )


def render(
    scene: Scene,
    method: Optional[str] = None,
    spp: Optional[int] = None,
    width: Optional[int] = None,
    height: Optional[int] = None,
    seed: Optional[int] = None,
    threads: Optional[int] = None,
    noise: Optional[float] = None,
    progress: Progress = None,
    *,
    bake: Optional[Bake] = None,
    tiles: Optional[int] = None,
    aa_spp: Optional[int] = None,
    crop: Optional[Tuple[int, int, int, int]] = None,
    max_memory: Optional[str] = None,
    passes: Optional[int] = None,
    time: Optional[float] = None,
    frame: Optional[int] = None,
) -> Result:
    """Renders a still scene, or frame ``frame`` of a camera walk from the walk's ``bake`` (made by
    ``bake(scene)``; as ``pmrender render --shared-bake``, the same pixels whichever frames are
    rendered, where and in what order). Arguments left None take the scene's (and ``load_file``'s)
    values.

    ``method``: ``pm`` (default), ``pm-fg``, ``photons`` or ``path``; ``noise``: adaptive sampling's
    target (0: every pixel takes ``spp``); ``progress``: True for a bar on stderr, or a callable given
    the fraction done (on this thread). With ``bake``, only pass B runs, from the bake's photon maps
    and caches: the same pixels as the render that would have made it. With ``tiles``, the image is
    shaded as that many bands of rows apart from one bake, as ``pmrender render --tiles`` and the farm
    do (see ``tile_windows``). ``passes``: a progressive render of that many passes, their mean (as
    ``--passes``, the same pixels); ``time``: a budget in seconds (as ``--time``).
    """
    if bake is not None and not isinstance(bake, Bake):
        raise ValueError("bake: must come from pmrender.bake or pmrender.load_bake")
    if frame is not None and _int("frame", frame) < 0:
        raise ValueError(f"frame: {frame} is not a frame number (0 or more)")
    result = Result(
        _native.render(
            scene,
            method=method,
            spp=_int("spp", spp),
            width=_int("width", width),
            height=_int("height", height),
            seed=_int("seed", seed),
            threads=_int("threads", threads),
            noise=noise,
            aa_spp=_int("aa_spp", aa_spp),
            crop=crop,
            max_memory=max_memory,
            progress=_progress(progress),
            bake=None if bake is None else bake._native,
            tiles=_int("tiles", tiles),
            passes=_int("passes", passes),
            time=time,
            frame=_int("frame", frame),
        )
    )
    _warn(result._native)
    return result


def bake(
    scene: Scene,
    method: Optional[str] = None,
    spp: Optional[int] = None,
    width: Optional[int] = None,
    height: Optional[int] = None,
    seed: Optional[int] = None,
    threads: Optional[int] = None,
    noise: Optional[float] = None,
    progress: Progress = None,
    *,
    aa_spp: Optional[int] = None,
    crop: Optional[Tuple[int, int, int, int]] = None,
    max_memory: Optional[str] = None,
) -> Bake:
    """Makes what ``render`` with the same arguments shades from — the photon maps and, for ``pm``,
    the media, glossy and irradiance caches (pass A) — without shading. Of an animated scene whose
    frames share one scene (only the camera moves), the walk's bake: photon maps traced once and one
    cache filled over every frame's view, for ``render(scene, bake=..., frame=f)``."""
    return Bake(
        _native.bake(
            scene,
            method=method,
            spp=_int("spp", spp),
            width=_int("width", width),
            height=_int("height", height),
            seed=_int("seed", seed),
            threads=_int("threads", threads),
            noise=noise,
            aa_spp=_int("aa_spp", aa_spp),
            crop=crop,
            max_memory=max_memory,
            progress=_progress(progress),
        )
    )


def load_bake(path: PathLike) -> Bake:
    """Reads a bake saved by ``Bake.save``; it is checked against the scene when rendered."""
    return Bake(_native.load_bake(os.fspath(path)))


def render_sequence(
    scene: Scene,
    frames: Optional[Union[range, Sequence[int]]] = None,
    method: Optional[str] = None,
    spp: Optional[int] = None,
    width: Optional[int] = None,
    height: Optional[int] = None,
    seed: Optional[int] = None,
    threads: Optional[int] = None,
    noise: Optional[float] = None,
    progress: Progress = None,
    *,
    chunk: Optional[int] = None,
    aa_spp: Optional[int] = None,
    max_memory: Optional[str] = None,
) -> Iterator[Tuple[int, Result]]:
    """Renders an animated scene's frames (``frames``: consecutive frame numbers, e.g.
    ``range(0, 8)``; default all) with temporal caching, as the CLI does, yielding
    ``(frame, Result)`` as each is done. The next frame renders while you work on this one; leaving
    the loop early stops the render. ``chunk``: the temporal cache starts afresh every ``chunk``
    frames (``pmrender render --chunk``); a range starting inside a chunk renders the chunk from its
    first frame, so every frame is the one the whole sequence gives."""
    span = None
    if frames is not None:
        fs = list(frames)
        if not fs:
            raise ValueError("frames: no frame given")
        if any(not isinstance(f, (int, np.integer)) or isinstance(f, bool) for f in fs):
            raise ValueError("frames: frame numbers must be whole numbers")
        if fs != list(range(fs[0], fs[0] + len(fs))) or fs[0] < 0:
            raise ValueError("frames: must be consecutive frame numbers from 0 up, e.g. range(2, 8)")
        span = (int(fs[0]), int(fs[-1]))
    native = _native.render_sequence(
        scene,
        frames=span,
        method=method,
        spp=_int("spp", spp),
        width=_int("width", width),
        height=_int("height", height),
        seed=_int("seed", seed),
        threads=_int("threads", threads),
        noise=noise,
        aa_spp=_int("aa_spp", aa_spp),
        max_memory=max_memory,
        chunk=_int("chunk", chunk),
        progress=_progress(progress),
    )
    return ((f, Result(r)) for f, r in native)


def converge(
    scene: Scene,
    photons: Optional[Sequence[float]],
    reference: PathLike,
    method: str = "photons",
    spp: Optional[int] = None,
    seed: Optional[int] = None,
    threads: Optional[int] = None,
    out: Optional[PathLike] = None,
    progress: Progress = None,
    time: Optional[Sequence[float]] = None,
) -> List[dict]:
    """The ``converge`` command's study: at each photon count (both maps' targets) a render at the
    reference's size, and its relMSE against the reference (an EXR or HDR) for the beauty and the
    ``caustic`` and ``indirect`` terms. Returns one row per count (``photons``, ``time_s``,
    ``beauty``, ``caustic``, ``indirect``; NaN where a term has no reference); with ``out``, also
    writes ``converge.md``, ``converge.json`` and ``converge.png`` there. With ``time`` (budgets in
    seconds) and ``photons=None``, the study is of progressive renders at those budgets instead
    (rows also give ``budget_s`` and ``passes``)."""
    counts = [float(n) for n in (photons or [])]
    return _native.converge(
        scene,
        photons=counts,
        reference=os.fspath(reference),
        method=method,
        spp=_int("spp", spp),
        seed=_int("seed", seed),
        threads=_int("threads", threads),
        out=_opt_path(out),
        progress=_progress(progress),
        time=None if time is None else [float(t) for t in time],
    )


def read_image(path: PathLike, layer: Optional[str] = None) -> np.ndarray:
    """An image file as float32 H×W×3: an EXR's beauty (R, G, B), or its layer ``layer``
    (``caustic.R`` ...), as the renderer reads references."""
    width, height, buf = _native.read_image(os.fspath(path), layer)
    return _pixels(buf, width, height)


def tile_windows(width: int, height: int, n: int) -> List[Tuple[int, int, int, int]]:
    """The tiles ``render(tiles=n)`` and the farm split a width×height image into: bands of rows,
    each ``(x0, y0, x1, y1)``."""
    return _native.tile_windows(width, height, n)
