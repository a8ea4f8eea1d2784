"""Float RGB EXR reading and writing for the tools: OpenImageIO's Python bindings when importable,
otherwise Mitsuba's Bitmap (any installed variant). Not a command.

read_rgb(path, layer=None) returns a float32 numpy array (height, width, 3): the channels R, G, B
(pmrender's beauty), or `LAYER.R`, `LAYER.G`, `LAYER.B` when a layer is named.
"""
import numpy as np


def _names(layer):
    return [f"{layer}.{c}" if layer else c for c in ("R", "G", "B")]


def _read_oiio(path, layer):
    import OpenImageIO as oiio
    inp = oiio.ImageInput.open(path)
    if inp is None:
        raise OSError(f"{path}: {oiio.geterror()}")
    spec = inp.spec()
    data = inp.read_image(0, 0, 0, spec.nchannels, "float")
    inp.close()
    names = list(spec.channelnames)
    idx = [names.index(n) for n in _names(layer)]
    return np.asarray(data, dtype=np.float32).reshape(spec.height, spec.width, spec.nchannels)[:, :, idx]


def _mitsuba():
    import mitsuba as mi
    if mi.variant() is None:
        mi.set_variant("scalar_rgb")
    return mi


def _read_mitsuba(path, layer):
    mi = _mitsuba()
    bmp = mi.Bitmap(path)
    arr = np.array(bmp, copy=False).astype(np.float32)
    if arr.ndim == 2:
        arr = arr[:, :, None]
    names = [bmp.struct_()[i].name for i in range(bmp.channel_count())]
    want = _names(layer)
    if all(n in names for n in want):
        return arr[:, :, [names.index(n) for n in want]]
    if layer is None and arr.shape[2] >= 3:
        return arr[:, :, :3]
    raise KeyError(f"{path}: no channels {want} (has {names})")


def read_rgb(path, layer=None):
    try:
        import OpenImageIO  # noqa: F401
    except ImportError:
        return _read_mitsuba(path, layer)
    return _read_oiio(path, layer)


def write_rgb(path, img):
    """Writes a (height, width, 3) float array as a float32 RGB EXR."""
    mi = _mitsuba()
    arr = np.ascontiguousarray(img, dtype=np.float32)
    mi.Bitmap(arr, mi.Bitmap.PixelFormat.RGB).write(path)
