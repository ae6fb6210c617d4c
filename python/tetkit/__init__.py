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
from ._tetkit import Bundle, Table, TetkitError, TetkitIOError, __version__

__all__ = [
    "Bundle",
    "Image",
    "Table",
    "bake",
    "TetkitError",
    "TetkitIOError",
    "COLORMAPS",
    "load",
    "read",
    "from_arrays",
    "from_meshio",
    "from_pyvista",
    "render",
    "reference",
    "diff",
    "tonemap",
    "methods",
    "interact",
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


#: meshio cell type names → VTK cell type ids (volume cells; others are skipped).
_MESHIO_VTK = {
    "tetra": 10, "hexahedron": 12, "wedge": 13, "pyramid": 14, "tetra10": 24, "hexahedron20": 25,
    "wedge15": 26, "pyramid13": 27, "hexahedron27": 29, "wedge12": 31, "wedge18": 32, "hexahedron24": 33,
    # as meshio names the Lagrange and Bezier cells it reads from VTK files (VTK's node orders)
    "VTK_LAGRANGE_TETRAHEDRON": 71, "VTK_LAGRANGE_HEXAHEDRON": 72, "VTK_LAGRANGE_WEDGE": 73,
    "VTK_BEZIER_TETRAHEDRON": 78, "VTK_BEZIER_HEXAHEDRON": 79, "VTK_BEZIER_WEDGE": 80,
}


def _fields(name: str, data: Any, keys: Any, count: int) -> list:
    out = []
    for k in keys:
        a = _np.asarray(data[k])
        if a.dtype.kind not in "fiub":
            continue  # strings and objects are no scalars
        out.append((str(k), _np.ascontiguousarray(a.reshape(count, -1) if a.ndim > 2 else a, dtype=_np.float64)))
    return out


def _points3(name: str, points: Any) -> _np.ndarray:
    p = _array(name, points, _np.float64, 2, "fiu")
    if p.shape[1] == 2:  # planar points: z = 0 (meshio stores 2D meshes so)
        p = _np.hstack([p, _np.zeros((p.shape[0], 1))])
    return p


def from_meshio(mesh: Any, scalar: Optional[str] = None) -> Bundle:
    """A bundle from a meshio ``Mesh`` (no temporary file): its volume cell
    blocks (tetrahedra, hexahedra, wedges, pyramids, their quadratic forms and
    VTK's Lagrange and Bezier tetrahedra, hexahedra and wedges) split into
    tets as ``tetprep convert`` splits them, other blocks
    skipped; ``scalar`` picks a point or cell field as ``--scalar`` does
    (``NAME``, ``NAME:mag``, ``NAME:x``…; default: the first point field,
    else the first cell field)."""
    points = _points3("mesh.points", mesh.points)
    types, ends, conn, kept, total = [], [], [], [], 0
    for b, block in enumerate(mesh.cells):
        vtk = _MESHIO_VTK.get(block.type)
        if vtk is None:
            continue
        data = _np.asarray(block.data, dtype=_np.int64)
        kept.append(b)
        types.append(_np.full(len(data), vtk, dtype=_np.int64))
        conn.append(data.reshape(-1))
        ends.append(total + data.shape[1] * _np.arange(1, len(data) + 1, dtype=_np.int64))
        total += data.size
    if not kept:
        raise TetkitError(f"mesh: no volume cells (blocks: {', '.join(b.type for b in mesh.cells) or 'none'})")
    types = _np.concatenate(types)
    offsets = _np.concatenate([_np.zeros(1, dtype=_np.int64)] + ends)
    conn = _np.concatenate(conn)
    point_fields = _fields("point", mesh.point_data, list(mesh.point_data), len(points))
    cell_data = {k: _np.concatenate([_np.asarray(v[b]) for b in kept]) for k, v in mesh.cell_data.items()}
    cell_fields = _fields("cell", cell_data, list(cell_data), len(types))
    return _tetkit.from_cells(points, types, offsets, conn, point_fields, cell_fields, scalar, None, "meshio")


def from_pyvista(grid: Any, scalar: Optional[str] = None) -> Bundle:
    """A bundle from a PyVista dataset (no temporary file): an
    ``UnstructuredGrid`` by its cells (split as ``tetprep convert`` splits
    them), an ``ImageData``/``StructuredGrid``/``RectilinearGrid`` by its
    points and dimensions (the structured 5-tet split); ``scalar`` picks a
    point or cell array as ``--scalar`` does (default: the active scalars,
    else the first point array, else the first cell array)."""
    if not (hasattr(grid, "points") and (hasattr(grid, "celltypes") or hasattr(grid, "dimensions"))):
        raise TetkitError(f"grid: a {type(grid).__name__} is no PyVista UnstructuredGrid, ImageData or StructuredGrid")
    points = _points3("grid.points", grid.points)
    if hasattr(grid, "celltypes"):
        types = _np.asarray(grid.celltypes, dtype=_np.int64)
        offsets = _np.asarray(grid.cell_offsets if hasattr(grid, "cell_offsets") else grid.offset, dtype=_np.int64)
        conn = _np.asarray(grid.cell_connectivity, dtype=_np.int64)
        dims = None
        n_cells = len(types)
    else:
        dims = tuple(int(d) for d in grid.dimensions)
        types = offsets = conn = _np.zeros(0, dtype=_np.int64)
        n_cells = int(_np.prod([max(d - 1, 1) for d in dims]))
    if scalar is None:
        active = getattr(grid, "active_scalars_name", None)
        scalar = active or None
    point_fields = _fields("point", grid.point_data, list(grid.point_data.keys()), len(points))
    cell_fields = _fields("cell", grid.cell_data, list(grid.cell_data.keys()), n_cells)
    return _tetkit.from_cells(points, types, offsets, conn, point_fields, cell_fields, scalar, dims, "PyVista")


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


def _light_args(light_dir: Any, shadows: bool) -> dict:
    args = {"shadows": bool(shadows)}
    if light_dir is not None:
        try:
            x, y, z = light_dir
            args["light_dir"] = (float(x), float(y), float(z))
        except (TypeError, ValueError):
            raise TetkitError(f"light_dir: expected (x, y, z), got {light_dir!r}") from None
    return args


def _progress(progress: Any, what: str) -> Any:
    """The native progress callback: a callable ``f(done, total)`` as it
    is; ``True``: a tqdm bar where tqdm is installed (else none); ``None``
    or ``False``: none."""
    if progress is None or progress is False:
        return None
    if callable(progress):
        return progress
    try:
        from tqdm.auto import tqdm
    except ImportError:
        return None
    bar = tqdm(total=1, desc=what, unit="tile", leave=False)

    def update(done: int, total: int) -> None:
        bar.total = total
        bar.n = done
        bar.refresh()
        if done >= total:
            bar.close()

    return update


def _at(bundle: Bundle, time: Optional[float]) -> Bundle:
    if not isinstance(bundle, Bundle):
        raise TetkitError(f"bundle: expected a tetkit.Bundle, got {type(bundle).__name__}")
    return bundle if time is None else bundle.at_time(float(time))


def render(bundle: Bundle, tf: TfLike = None, method: str = "table3d", view: Any = None, azimuth: float = 0.0,
           elevation: float = 0.0, zoom: float = 1.0, size: Tuple[int, int] = (512, 512), renderer: str = "walk",
           lut: Optional[PathLike] = None, light: bool = False, cull: bool = True,
           time: Optional[float] = None, stats: bool = False, table: Optional[Table] = None,
           progress: Any = None, light_dir: Optional[Tuple[float, float, float]] = None,
           shadows: bool = False, adaptive: Optional[float] = None) -> Any:
    """Renders on the CPU as ``tetview render`` does: the same TF policy,
    table bake (``method``: see :func:`methods`), ``table`` (from
    :func:`bake`: drawn with its TF and method) or ``lut`` file, ``renderer``
    (``walk`` or ``pt`` on the CPU, or ``gpu``: projected tetrahedra on the
    GPU as ``tetview render --gpu``, unlit, for the methods the GPU has; a
    ``TetkitError`` where no GPU adapter exists) and view (``view``: VTK camera fields as a dict or
    a view JSON file; else the default framing turned by ``azimuth`` and
    ``elevation`` degrees and ``zoom``). ``time`` draws a time series at
    that time. Returns an :class:`Image`, or with ``stats`` the pair
    (image, dict of the frame's figures: ``engine_seconds`` spent in the
    engine — bake or load, scene, frame — ``frame_seconds``, ``renderer``,
    ``tets_drawn``, ``tets_culled``, ``crossings``, ``fragments``).
    ``progress``: a callable ``f(done, total)`` over tiles, or ``True`` for
    a tqdm bar where tqdm is installed. Lighting as ``tetview render``'s:
    ``light`` (a headlight), ``light_dir`` (one directional light
    travelling along that world direction), the view's ``"lighting"``
    object (several lights; it turns lighting on), and ``shadows``
    (volumetric shadows of every light but the headlight). ``adaptive``
    (walker only): a preview by image-space adaptive sampling at that
    tolerance, as ``tetview render --adaptive`` (faster where the image is
    smooth; its error measured, not bounded; the figures' ``rays_walked``
    and ``rays_interpolated`` say how many pixels it walked)."""
    args = _view_args(view, azimuth, elevation, zoom, size)
    args.update(_light_args(light_dir, shadows))
    args.update(_tf_args(tf))
    if lut is not None:
        args["lut"] = _path("lut", lut)
    if table is not None and not isinstance(table, Table):
        raise TetkitError(f"table: expected a tetkit.Table from tetkit.bake, got {type(table).__name__}")
    img, figures = _tetkit.render(_at(bundle, time), method=method, renderer=renderer, light=bool(light),
                                  cull=bool(cull), table=table, progress=_progress(progress, "render"),
                                  adaptive=None if adaptive is None else float(adaptive), **args)
    return (Image(img), figures) if stats else Image(img)


def bake(bundle: Bundle, tf: TfLike = None, method: str = "table3d") -> Table:
    """Bakes ``method``'s pre-integration tables for ``tf`` over the
    bundle's domain, as ``tetview render`` does before drawing (table3d:
    certified against the exact integral, see ``Table.certificate``).
    Render with them (``render(bundle, table=t)``) or save them
    (``t.save("b.tetl")``, what ``tetview render --lut`` reads)."""
    return _tetkit.bake(_at(bundle, None), method=method, **_tf_args(tf))


def reference(bundle: Bundle, tf: TfLike = None, view: Any = None, azimuth: float = 0.0, elevation: float = 0.0,
              zoom: float = 1.0, size: Tuple[int, int] = (512, 512), time: Optional[float] = None,
              progress: Any = None, light: bool = False, light_dir: Optional[Tuple[float, float, float]] = None,
              shadows: bool = False) -> Image:
    """The exact ray-cast reference (``tetview reference``) of the same
    view and TF: the ground truth :func:`diff` compares with. With
    lighting (as :func:`render`'s) it integrates the lighting along every
    ray and casts exact shadow rays."""
    args = _view_args(view, azimuth, elevation, zoom, size)
    args.update(_tf_args(tf))
    args.update(_light_args(light_dir, shadows))
    args["light"] = bool(light)
    return Image(_tetkit.reference(_at(bundle, time), progress=_progress(progress, "reference"), **args))


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


def interact(bundle: Bundle, tf: TfLike = None, method: str = "table3d", size: Tuple[int, int] = (384, 384)) -> Any:
    """A notebook widget: sliders for azimuth, elevation, zoom and the TF's
    opacity scale (and time, for a time series) redraw the bundle. The table
    is baked once (again only when the opacity scale moves). Needs
    ipywidgets (``pip install ipywidgets``); without it, an ImportError
    saying so."""
    try:
        import ipywidgets as w
        from IPython.display import display
    except ImportError as e:
        raise ImportError("tetkit.interact needs ipywidgets and IPython: pip install ipywidgets") from e
    if isinstance(tf, Mapping):
        base = dict(tf)
    elif tf is None or (isinstance(tf, str) and tf in COLORMAPS):
        base = None
    else:
        with open(_path("tf", tf), encoding="utf-8") as f:
            base = _json.load(f)
    tables = {}

    def table_for(scale: float) -> Table:
        key = round(scale, 3)
        if key not in tables:
            if base is None:
                tables.clear()
                tables[key] = bake(bundle, tf, method)
            else:
                scaled = dict(base)
                scaled["opacity"] = [[x, a * scale] for x, a in base["opacity"]]
                tables.clear()
                tables[key] = bake(bundle, scaled, method)
        return tables[key]

    out = w.Image(format="png")
    controls = {
        "azimuth": w.FloatSlider(value=0, min=-180, max=180, step=5, description="azimuth"),
        "elevation": w.FloatSlider(value=20, min=-89, max=89, step=5, description="elevation"),
        "zoom": w.FloatLogSlider(value=1, base=2, min=-2, max=3, step=0.1, description="zoom"),
        "scale": w.FloatLogSlider(value=1, base=10, min=-2, max=2, step=0.05, description="opacity",
                                  disabled=base is None),
    }
    times = bundle.times
    if times:
        controls["time"] = w.FloatSlider(value=times[0], min=times[0], max=times[-1],
                                         step=(times[-1] - times[0]) / 100 or 1, description="time")

    def draw(**v: Any) -> None:
        t = table_for(v["scale"])
        img = render(bundle, table=t, azimuth=v["azimuth"], elevation=v["elevation"], zoom=v["zoom"], size=size,
                     time=v.get("time"))
        out.value = img.png()

    ui = w.interactive(draw, **controls)
    display(w.VBox([out, ui]))
    draw(**{k: c.value for k, c in controls.items()})
    return ui
