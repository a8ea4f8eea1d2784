"""Type stubs of pmrender's native module (the package ``pmrender`` wraps it)."""

from typing import Callable, Iterator, List, Optional, Tuple

class SceneError(ValueError):
    """A scene file (or a file it names) is wrong."""

    path: str
    line: Optional[int]

class Scene:
    @property
    def path(self) -> str: ...
    @property
    def frames(self) -> Optional[int]: ...
    @property
    def size(self) -> Optional[Tuple[int, int]]: ...
    @property
    def triangles(self) -> Optional[int]: ...

class RenderResult:
    @property
    def width(self) -> int: ...
    @property
    def height(self) -> int: ...
    def image_bytes(self) -> bytearray: ...
    def layer_names(self) -> List[str]: ...
    def layer_bytes(self, name: str) -> bytearray: ...
    def stats_json(self) -> str: ...
    def warnings(self) -> List[str]: ...
    def write(
        self,
        path: str,
        *,
        png: Optional[str] = ...,
        stats: Optional[str] = ...,
        save_cache: Optional[str] = ...,
        cache_image: Optional[str] = ...,
    ) -> None: ...

class Bake:
    @property
    def method(self) -> str: ...
    def stats_json(self) -> Optional[str]: ...
    def save(self, path: str) -> None: ...
    def to_bytes(self) -> bytes: ...

class Frames(Iterator[Tuple[int, RenderResult]]):
    def __iter__(self) -> "Frames": ...
    def __next__(self) -> Tuple[int, RenderResult]: ...

def load_file(
    path: str,
    *,
    method: Optional[str] = ...,
    spp: Optional[int] = ...,
    noise: Optional[float] = ...,
    aa_spp: Optional[int] = ...,
    width: Optional[int] = ...,
    height: Optional[int] = ...,
    seed: Optional[int] = ...,
    crop: Optional[Tuple[int, int, int, int]] = ...,
    max_memory: Optional[str] = ...,
) -> Scene: ...
def render(
    scene: Scene,
    *,
    method: Optional[str] = ...,
    spp: Optional[int] = ...,
    width: Optional[int] = ...,
    height: Optional[int] = ...,
    seed: Optional[int] = ...,
    threads: Optional[int] = ...,
    noise: Optional[float] = ...,
    aa_spp: Optional[int] = ...,
    crop: Optional[Tuple[int, int, int, int]] = ...,
    max_memory: Optional[str] = ...,
    progress: Optional[Callable[[float], object]] = ...,
    bake: Optional[Bake] = ...,
    tiles: Optional[int] = ...,
    passes: Optional[int] = ...,
    time: Optional[float] = ...,
    frame: Optional[int] = ...,
) -> RenderResult: ...
def bake(
    scene: Scene,
    *,
    method: Optional[str] = ...,
    spp: Optional[int] = ...,
    width: Optional[int] = ...,
    height: Optional[int] = ...,
    seed: Optional[int] = ...,
    threads: Optional[int] = ...,
    noise: Optional[float] = ...,
    aa_spp: Optional[int] = ...,
    crop: Optional[Tuple[int, int, int, int]] = ...,
    max_memory: Optional[str] = ...,
    progress: Optional[Callable[[float], object]] = ...,
) -> Bake: ...
def load_bake(path: str) -> Bake: ...
def render_sequence(
    scene: Scene,
    *,
    frames: Optional[Tuple[int, int]] = ...,
    method: Optional[str] = ...,
    spp: Optional[int] = ...,
    width: Optional[int] = ...,
    height: Optional[int] = ...,
    seed: Optional[int] = ...,
    threads: Optional[int] = ...,
    noise: Optional[float] = ...,
    aa_spp: Optional[int] = ...,
    max_memory: Optional[str] = ...,
    chunk: Optional[int] = ...,
    progress: Optional[Callable[[float], object]] = ...,
) -> Frames: ...
def converge(
    scene: Scene,
    *,
    photons: List[float],
    reference: str,
    method: str = ...,
    spp: Optional[int] = ...,
    seed: Optional[int] = ...,
    threads: Optional[int] = ...,
    out: Optional[str] = ...,
    progress: Optional[Callable[[float], object]] = ...,
    time: Optional[List[float]] = ...
) -> List[dict]: ...
def read_image(path: str, layer: Optional[str] = ...) -> Tuple[int, int, bytearray]: ...
def write_exr(
    path: str,
    width: int,
    height: int,
    beauty: bytes,
    layers: List[Tuple[str, bytes]],
    png: Optional[str] = ...,
) -> None: ...
def tile_windows(width: int, height: int, n: int) -> List[Tuple[int, int, int, int]]: ...
def bake_from_bytes(data: bytes) -> Bake: ...
