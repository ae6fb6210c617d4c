"""tetkit: accurate, fast direct volume rendering of unstructured data.

Bundles come from files (``read``: any mesh, grid, volume or point cloud
that ``tetprep convert`` reads; ``load``: a ``.tetb``) or from numpy arrays
(``from_arrays``). ``render`` draws one on the CPU as ``tetview render``
does, to an :class:`Image` (an H×W×4 float32 numpy array of linear
premultiplied RGBA that shows itself in notebooks); ``reference`` draws the
exact ray-cast ground truth; ``diff`` measures the error between two.

Errors are :class:`TetkitError` (a ``ValueError``: bad arguments or data)
or :class:`TetkitIOError` (an ``OSError``: a file that cannot be read or
written), with the command-line programs' messages.
"""

from __future__ import annotations

import json as _json
import os as _os
from typing import Any, Mapping, Optional, Tuple, Union

import numpy as _np

from . import _tetkit
from ._tetkit import Bundle, TetkitError, TetkitIOError, __version__

__all__ = [
    "Bundle",
    "Image",
    "TetkitError",
    "TetkitIOError",
    "COLORMAPS",
    "load",
    "read",
    "from_arrays",
    "render",
    "reference",
    "diff",
    "tonemap",
    "methods",
    "__version__",
]

#: Colour maps a ``tf`` string may name (the automatic TF with that map).
COLORMAPS = ("viridis", "inferno", "magma", "plasma", "cool-to-warm", "turbo", "grayscale")

PathLike = Union[str, "_os.PathLike[str]"]
TfLike = Union[None, str, "_os.PathLike[str]", Mapping[str, Any]]


class Image(_np.ndarray):
    """An H×W×4 float32 array of linear premultiplied RGBA (row 0 at the
    top) that shows itself, tone mapped as ``tetview render`` writes its
    PNG, in notebooks. Every numpy operation works on it."""

    def __new__(cls, array: _np.ndarray) -> "Image":
        return _np.asarray(array, dtype=_np.float32).view(cls)

    def to_rgba8(self, exposure: float = 1.0, background: Tuple[float, float, float] = (0.0, 0.0, 0.0),
                 reinhard: bool = True) -> _np.ndarray:
        """8-bit sRGB RGBA (H×W×4 uint8) after compositing over
        ``background`` and Reinhard tone mapping (``reinhard=False``: clamp)."""
        return tonemap(self, exposure=exposure, background=background, reinhard=reinhard)

    def png(self, **display: Any) -> bytes:
        """PNG bytes of :meth:`to_rgba8`."""
        return _tetkit.encode_png(self.to_rgba8(**display))

    def save(self, path: PathLike, **display: Any) -> None:
        """Writes the PNG (``.png``) or the float array (``.npy``, what
        ``tetview diff`` reads)."""
        p = _os.fspath(path)
        if p.lower().endswith(".npy"):
            _np.save(p, _np.asarray(self, dtype=_np.float32))
        else:
            with open(p, "wb") as f:
                f.write(self.png(**display))

    def _repr_png_(self) -> bytes:
        return self.png()


def _path(name: str, value: PathLike) -> str:
    try:
        return _os.fspath(value)
    except TypeError:
        raise TetkitError(f"{name}: expected a path (str or os.PathLike), got {type(value).__name__}") from None


def load(path: PathLike) -> Bundle:
    """Reads a bundle written by ``tetprep convert`` (``.tetb``)."""
    return _tetkit.load(_path("path", path))


def read(path: PathLike, scalar: Optional[str] = None, q: Optional[PathLike] = None,
         all_steps: bool = False) -> Bundle:
    """Reads any file ``tetprep convert`` reads and converts it with its
    defaults: cells split into tets, duplicate points merged, point clouds
    tetrahedralized (Delaunay), a ``.pvd`` or ``.series`` as a time series
    (``all_steps``: every step of an Exodus file or OpenFOAM case).
    ``scalar`` picks the field (``NAME``, ``NAME:x``, ``NAME:mag``, ``x``…);
    ``q`` is a PLOT3D solution file. A ``.tetb`` is loaded as it is."""
    p = _path("path", path)
    if p.lower().endswith(".tetb"):
        return _tetkit.load(p)
    return _tetkit.read(p, scalar, None if q is None else _path("q", q), bool(all_steps))


def _array(name: str, value: Any, dtype: Any, ndim: int, kind: str) -> _np.ndarray:
    a = _np.asarray(value)
    if a.dtype.kind not in kind:
        raise TetkitError(f"{name}: dtype {a.dtype} is not {'an integer' if kind == 'iu' else 'a real'} type")
    if a.ndim != ndim:
        raise TetkitError(f"{name}: shape {a.shape} has {a.ndim} dimensions, need {ndim}")
    return _np.ascontiguousarray(a, dtype=dtype)


def from_arrays(points: Any, tets: Any, scalars: Any) -> Bundle:
    """A bundle from numpy arrays: ``points`` N×3 (float), ``tets`` M×4
    point indices (integer; any orientation, flat tets dropped), ``scalars``
    one value a point (N) or a tet (M, averaged onto the points by volume).
    Validated as ``tetprep convert`` validates a tet mesh."""
    p = _array("points", points, _np.float64, 2, "fiu")
    t = _array("tets", tets, _np.int64, 2, "iu")
    s = _array("scalars", scalars, _np.float64, 1, "fiu")
    return _tetkit.from_arrays(p, t, s)


def _tf_args(tf: TfLike) -> dict:
    """The native TF arguments of ``tf``: a dict (the TF JSON schema of
    formats/tf.md), a file path (tetkit JSON or a ParaView preset), a colour
    map name (the automatic TF in that map), or None (the automatic TF)."""
    if tf is None:
        return {}
    if isinstance(tf, Mapping):
        return {"tf_json": _json.dumps(tf)}
    if isinstance(tf, str) and tf in COLORMAPS:
        return {"colormap": tf}
    return {"tf_path": _path("tf", tf)}


def _view_args(view: Any, azimuth: float, elevation: float, zoom: float, size: Tuple[int, int]) -> dict:
    args = {"azimuth": float(azimuth), "elevation": float(elevation), "zoom": float(zoom)}
    try:
        w, h = size
        args["size"] = (int(w), int(h))
    except (TypeError, ValueError):
        raise TetkitError(f"size: expected (width, height), got {size!r}") from None
    if view is not None:
        if isinstance(view, Mapping):
            args["view_json"] = _json.dumps(dict(view))
        else:
            with open(_path("view", view), encoding="utf-8") as f:
                args["view_json"] = f.read()
    return args


def _at(bundle: Bundle, time: Optional[float]) -> Bundle:
    if not isinstance(bundle, Bundle):
        raise TetkitError(f"bundle: expected a tetkit.Bundle, got {type(bundle).__name__}")
    return bundle if time is None else bundle.at_time(float(time))


def render(bundle: Bundle, tf: TfLike = None, method: str = "table3d", view: Any = None, azimuth: float = 0.0,
           elevation: float = 0.0, zoom: float = 1.0, size: Tuple[int, int] = (512, 512), renderer: str = "walk",
           lut: Optional[PathLike] = None, light: bool = False, cull: bool = True,
           time: Optional[float] = None, stats: bool = False) -> Any:
    """Renders on the CPU as ``tetview render`` does: the same TF policy,
    table bake (``method``: see :func:`methods`) or ``lut`` file, ``renderer``
    (``walk`` or ``pt``) and view (``view``: VTK camera fields as a dict or
    a view JSON file; else the default framing turned by ``azimuth`` and
    ``elevation`` degrees and ``zoom``). ``time`` draws a time series at
    that time. Returns an :class:`Image`, or with ``stats`` the pair
    (image, dict of the frame's figures: ``engine_seconds`` spent in the
    engine — bake or load, scene, frame — ``frame_seconds``, ``renderer``,
    ``tets_drawn``, ``tets_culled``, ``crossings``, ``fragments``)."""
    args = _view_args(view, azimuth, elevation, zoom, size)
    args.update(_tf_args(tf))
    if lut is not None:
        args["lut"] = _path("lut", lut)
    img, figures = _tetkit.render(_at(bundle, time), method=method, renderer=renderer, light=bool(light),
                                  cull=bool(cull), **args)
    return (Image(img), figures) if stats else Image(img)


def reference(bundle: Bundle, tf: TfLike = None, view: Any = None, azimuth: float = 0.0, elevation: float = 0.0,
              zoom: float = 1.0, size: Tuple[int, int] = (512, 512), time: Optional[float] = None) -> Image:
    """The exact ray-cast reference (``tetview reference``) of the same
    view and TF: the ground truth :func:`diff` compares with."""
    args = _view_args(view, azimuth, elevation, zoom, size)
    args.update(_tf_args(tf))
    return Image(_tetkit.reference(_at(bundle, time), **args))


def tonemap(image: Any, exposure: float = 1.0, background: Tuple[float, float, float] = (0.0, 0.0, 0.0),
            reinhard: bool = True) -> _np.ndarray:
    """8-bit sRGB RGBA (H×W×4 uint8) of a linear image, as ``tetview
    render`` writes its PNG."""
    a = _array("image", image, _np.float32, 3, "f")
    return _tetkit.tonemap(a, float(exposure), tuple(float(c) for c in background), bool(reinhard))


def diff(a: Any, b: Any) -> dict:
    """Differences of two linear images of one size, as ``tetview diff``
    prints them: ``rmse``, ``max_abs``, ``mean_abs`` (all four channels of
    linear premultiplied RGBA) and ``max_8bit`` (after tone mapping each)."""
    rmse, max_abs, mean_abs, max_8bit = _tetkit.diff(_array("a", a, _np.float32, 3, "f"),
                                                    _array("b", b, _np.float32, 3, "f"))
    return {"rmse": rmse, "max_abs": max_abs, "mean_abs": mean_abs, "max_8bit": max_8bit}


def methods() -> list:
    """The method ids :func:`render` takes."""
    return list(_tetkit.methods())
