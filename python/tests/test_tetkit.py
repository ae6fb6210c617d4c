"""The Python package as users call it: bundles from files and arrays,
renders equal to tetview's bit for bit, the reference and diff, time series,
notebook display, and bad input as Python exceptions naming the argument."""

import json
import os
import pathlib
import subprocess

import numpy as np
import pytest

import tetkit

ROOT = pathlib.Path(__file__).resolve().parents[2]
DATA = ROOT / "tests" / "data"
CUBE = ROOT / "formats" / "samples" / "cube5.tetb"
# A held-out style TF: narrow opacity peaks over the normalized range.
PEAKS = {
    "normalized": True,
    "color": [[0, 0.1, 0.2, 1], [0.5, 1, 0.9, 0.2], [1, 1, 0.1, 0]],
    "opacity": [v for c in (0.15, 0.32, 0.49, 0.66, 0.83) for v in ([c - 0.02, 0], [c, 8], [c + 0.02, 0])],
    "unit_distance": 1,
}


def bluntfin():
    return tetkit.read(DATA / "plot3d" / "bluntfinxyz.bin", scalar="density", q=DATA / "plot3d" / "bluntfinq.bin")


def test_load_and_properties():
    b = tetkit.load(CUBE)
    assert (b.num_points, b.num_tets) == (8, 5)
    assert b.points.shape == (8, 3) and b.points.dtype == np.float64
    assert b.tets.shape == (5, 4) and b.tets.dtype == np.uint32
    assert b.scalar.shape == (8,)
    assert b.scalar_range == (float(b.scalar.min()), float(b.scalar.max()))
    assert b.times is None
    assert "5 tets" in repr(b)


def test_from_arrays_is_the_same_mesh():
    b = tetkit.load(CUBE)
    a = tetkit.from_arrays(b.points, b.tets.astype(np.int32), b.scalar)
    assert (a.num_points, a.num_tets) == (8, 5)
    np.testing.assert_array_equal(a.points, b.points)
    # One value a tet: averaged onto the points by volume.
    c = tetkit.from_arrays(b.points, b.tets, np.arange(5.0))
    assert c.scalar.min() >= 0 and c.scalar.max() <= 4


@pytest.mark.parametrize(
    "points, tets, scalars, argument, words",
    [
        (np.zeros((4, 2)), [[0, 1, 2, 3]], [0, 1, 2, 3], "points", "N×3"),
        (["a"] * 4, [[0, 1, 2, 3]], [0, 1, 2, 3], "points", "dtype"),
        ([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, np.nan]], [[0, 1, 2, 3]], [0, 1, 2, 3], "points", "non-finite"),
        ([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], [[0, 1, 2, 9]], [0, 1, 2, 3], "tets", "point 9"),
        ([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], [[0, 1, 2, 3.5]], [0, 1, 2, 3], "tets", "integer"),
        ([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], [[0, 1, 2, 3]], [0, 1, 2], "scalars", "length 3"),
        ([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], [[0, 1, 2, 3]], [0, 1, np.inf, 3], "scalars", "inf"),
    ],
)
def test_bad_arrays_name_the_argument(points, tets, scalars, argument, words):
    with pytest.raises(tetkit.TetkitError) as e:
        tetkit.from_arrays(points, tets, scalars)
    assert str(e.value).startswith(argument) and words in str(e.value), str(e.value)
    assert isinstance(e.value, ValueError)


def test_files_that_cannot_be_read_are_oserrors():
    with pytest.raises(tetkit.TetkitIOError) as e:
        tetkit.load("/no/such/bundle.tetb")
    assert "/no/such/bundle.tetb" in str(e.value) and isinstance(e.value, OSError)
    with pytest.raises(OSError):
        tetkit.read(DATA / "no_such_file.vtu")
    with pytest.raises(tetkit.TetkitError) as e:
        tetkit.read(DATA / "vtk" / "hexa.vtk", scalar="nope")
    assert "no scalar named 'nope'" in str(e.value)


def tetview_on_bluntfin(tmp_path):
    """Blunt Fin saved where `tetview` reads it, PEAKS as a file, and a
    function that runs `tetview render` on them at 96x72, azimuth 40, with
    extra arguments, returning the process and the .npy it wrote."""
    tetview = os.environ.get("TETVIEW")
    if not tetview:
        pytest.skip("TETVIEW (the tetview binary) is not set; make test sets it")
    b = bluntfin()
    bundle_path, tf_path, npy = tmp_path / "bf.tetb", tmp_path / "peaks.json", tmp_path / "cli.npy"
    b.save(str(bundle_path))
    tf_path.write_text(json.dumps(PEAKS))

    def run(*extra, check=True):
        out = subprocess.run(
            [tetview, "render", str(bundle_path), "--tf", str(tf_path), "--size", "96x72", "--azimuth", "40",
             *extra, "-o", str(tmp_path / "x.png"), "--float", str(npy)], check=check, capture_output=True)
        return out, npy
    return b, tf_path, run


def test_render_equals_tetview_bit_for_bit(tmp_path):
    b, tf_path, tetview_render = tetview_on_bluntfin(tmp_path)
    for renderer in ("walk", "pt"):
        _, npy = tetview_render("--renderer", renderer)
        cli = np.load(npy)
        mine = tetkit.render(b, tf=PEAKS, size=(96, 72), azimuth=40, renderer=renderer)
        assert mine.shape == (72, 96, 4) and mine.dtype == np.float32
        assert cli.tobytes() == np.asarray(mine).tobytes(), renderer
        # A TF file and a TF dict are the same TF.
        assert np.asarray(tetkit.render(b, tf=tf_path, size=(96, 72), azimuth=40, renderer=renderer)).tobytes() \
            == cli.tobytes()
    # Adaptive sampling: the same preview through both, and bad tolerances refused.
    _, npy = tetview_render("--adaptive", "0.01")
    mine, figures = tetkit.render(b, tf=PEAKS, size=(96, 72), azimuth=40, adaptive=0.01, stats=True)
    assert np.load(npy).tobytes() == np.asarray(mine).tobytes()
    assert figures["rays_interpolated"] > 0 and figures["rays_walked"] > 0
    for bad, renderer in ((-0.5, "walk"), (float("nan"), "walk"), (0.01, "pt")):
        with pytest.raises(tetkit.TetkitError, match="adaptive"):
            tetkit.render(b, tf=PEAKS, size=(16, 16), adaptive=bad, renderer=renderer)


def test_gpu_renderer_equals_tetview_gpu(tmp_path):
    b, _, tetview_render = tetview_on_bluntfin(tmp_path)
    cli, npy = tetview_render("--gpu", check=False)
    if cli.returncode == 7:  # no GPU adapter
        if os.environ.get("TETKIT_REQUIRE_GPU") == "1":
            pytest.fail("TETKIT_REQUIRE_GPU=1 but tetview found no GPU: " + cli.stderr.decode())
        with pytest.raises(tetkit.TetkitError, match="GPU|adapter|device"):
            tetkit.render(b, tf=PEAKS, size=(96, 72), azimuth=40, renderer="gpu")
        pytest.skip("no GPU adapter: " + cli.stderr.decode().strip())
    assert cli.returncode == 0, cli.stderr.decode()
    mine, figures = tetkit.render(b, tf=PEAKS, size=(96, 72), azimuth=40, renderer="gpu", stats=True)
    assert figures["renderer"] == "gpu" and figures["tets_drawn"] > 0 and figures["device"]
    got, want = np.asarray(mine), np.load(npy)
    assert got.shape == want.shape and np.abs(got - want).max() <= 1e-6, np.abs(got - want).max()
    # The same picture as the CPU's projected tetrahedra (f32 lookups on the
    # device: RMSE 1.2e-3 with these narrow peaks on lavapipe, 2026-12-05).
    cpu = np.asarray(tetkit.render(b, tf=PEAKS, size=(96, 72), azimuth=40, renderer="pt"))
    assert np.sqrt(((got - cpu) ** 2).mean()) < 3e-3 and ((got[..., 3] > 0) == (cpu[..., 3] > 0)).mean() > 0.99
    with pytest.raises(tetkit.TetkitError, match="adaptive"):
        tetkit.render(b, tf=PEAKS, size=(16, 16), renderer="gpu", adaptive=0.01)


def test_lights_and_shadows_match_tetview_and_the_lit_reference(tmp_path):
    b = bluntfin()
    kw = dict(tf=PEAKS, size=(48, 40), azimuth=30, elevation=20)
    lit = tetkit.render(b, light_dir=(0.6, -0.5, -0.62), **kw)
    dark = tetkit.render(b, light_dir=(0.6, -0.5, -0.62), shadows=True, **kw)
    assert tetkit.diff(lit, dark)["max_abs"] > 1e-3
    # The lighting against the lit reference; shadows darken it (the
    # shadow field's own error is measured by
    # crates/tet_engine/results/lighting.sh, not bounded here).
    ref_lit = tetkit.reference(b, light_dir=(0.6, -0.5, -0.62), **kw)
    assert tetkit.diff(lit, ref_lit)["rmse"] < 5e-3
    ref_dark = np.asarray(tetkit.reference(b, light_dir=(0.6, -0.5, -0.62), shadows=True, **kw))
    assert np.isfinite(ref_dark).all()
    assert (ref_dark[..., :3] <= np.asarray(ref_lit)[..., :3] + 1e-6).all()
    with pytest.raises(tetkit.TetkitError, match="headlight casts no shadow"):
        tetkit.render(b, shadows=True, **kw)
    with pytest.raises(tetkit.TetkitError, match="light_dir"):
        tetkit.render(b, light_dir="up", **kw)
    tetview = os.environ.get("TETVIEW")
    if tetview:
        bundle_path, tf_path, npy = tmp_path / "bf.tetb", tmp_path / "peaks.json", tmp_path / "cli.npy"
        b.save(str(bundle_path))
        tf_path.write_text(json.dumps(PEAKS))
        subprocess.run(
            [tetview, "render", str(bundle_path), "--tf", str(tf_path), "--size", "48x40", "--azimuth", "30",
             "--elevation", "20", "--light-dir", "0.6,-0.5,-0.62", "--shadows", "-o", str(tmp_path / "x.png"),
             "--float", str(npy)],
            check=True, capture_output=True)
        assert np.load(npy).tobytes() == np.asarray(dark).tobytes()


def test_reference_diff_and_display():
    b = bluntfin()
    img = tetkit.render(b, tf=PEAKS, size=(64, 48), elevation=20)
    ref = tetkit.reference(b, tf=PEAKS, size=(64, 48), elevation=20)
    d = tetkit.diff(ref, img)
    assert set(d) == {"rmse", "max_abs", "mean_abs", "max_8bit"}
    assert 0 < d["rmse"] < 1e-2 and d["max_8bit"] <= 3, d
    assert tetkit.diff(img, img)["max_abs"] == 0
    png = img._repr_png_()
    assert png.startswith(b"\x89PNG\r\n\x1a\n")
    rgba = img.to_rgba8()
    assert rgba.shape == (48, 64, 4) and rgba.dtype == np.uint8 and rgba[..., :3].max() > 100
    with pytest.raises(tetkit.TetkitError):
        tetkit.diff(img, img[:10])
    # Every TF form: automatic, a colour map name, a dict.
    for tf in (None, "inferno", PEAKS):
        assert np.asarray(tetkit.render(b, tf=tf, size=(32, 24)))[..., 3].max() > 0
    with pytest.raises(tetkit.TetkitError) as e:
        tetkit.render(b, tf={"color": [], "opacity": []}, size=(8, 8))
    with pytest.raises(tetkit.TetkitError) as e:
        tetkit.render(b, method="nope", size=(8, 8))
    assert "nope" in str(e.value)
    with pytest.raises(tetkit.TetkitError):
        tetkit.render(b, size=(0, 8))


def test_time_series():
    s = tetkit.read(DATA / "series" / "isabel_eye.pvd")
    assert s.times == [2.0, 3.0, 4.0, 5.0]
    a = tetkit.render(s, tf=PEAKS, size=(40, 32), time=3.5)
    b = tetkit.render(s.at_time(3.5), tf=PEAKS, size=(40, 32))
    assert np.asarray(a).tobytes() == np.asarray(b).tobytes()
    assert np.asarray(a).tobytes() != np.asarray(tetkit.render(s, tf=PEAKS, size=(40, 32), time=2)).tobytes()
    with pytest.raises(tetkit.TetkitError) as e:
        s.at_time(9)
    assert "outside" in str(e.value)


def test_methods_render():
    b = tetkit.load(CUBE)
    assert "table3d" in tetkit.methods() and "exact" in tetkit.methods()
    for m in ("exact", "pt-linear", "table3d"):
        assert np.asarray(tetkit.render(b, method=m, size=(24, 24)))[..., 3].max() > 0, m


def hex_and_wedge():
    """A hexahedron and a wedge on its top, a triangle (no volume), a point
    scalar and a cell scalar: what meshio and PyVista hand over."""
    pts = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [0, 0, 1], [1, 0, 1], [1, 1, 1], [0, 1, 1],
                    [0.5, 0, 2], [0.5, 1, 2]], dtype=float)
    return pts, [("hexahedron", [[0, 1, 2, 3, 4, 5, 6, 7]]), ("wedge", [[4, 5, 8, 7, 6, 9]]),
                 ("triangle", [[0, 1, 2]])]


def test_from_meshio():
    meshio = pytest.importorskip("meshio")
    pts, blocks = hex_and_wedge()
    mesh = meshio.Mesh(pts, blocks, point_data={"t": pts[:, 2] * 2.0, "v": pts},
                       cell_data={"c": [np.array([1.0]), np.array([5.0]), np.array([9.0])]})
    b = tetkit.from_meshio(mesh)
    assert b.num_points == 10 and b.num_tets >= 6 + 3 - 1, b
    assert b.scalar_name == "t" and b.scalar_range == (0.0, 4.0)
    assert tetkit.from_meshio(mesh, scalar="v:mag").scalar_name == "v:mag"
    c = tetkit.from_meshio(mesh, scalar="c")
    assert 1.0 <= c.scalar.min() and c.scalar.max() <= 5.0
    with pytest.raises(tetkit.TetkitError) as e:
        tetkit.from_meshio(mesh, scalar="nope")
    assert "no scalar named 'nope'" in str(e.value) and "t (point)" in str(e.value)
    with pytest.raises(tetkit.TetkitError):
        tetkit.from_meshio(meshio.Mesh(pts, [("triangle", [[0, 1, 2]])]))


class FakeData(dict):
    """PyVista's DataSetAttributes as far as tetkit reads them."""


class FakeUnstructured:
    """The attributes of a pyvista.UnstructuredGrid that tetkit reads."""

    def __init__(self, pts, cells, point_data, cell_data):
        self.points = pts
        self.celltypes = np.array([t for t, _ in cells], dtype=np.uint8)
        self.cell_connectivity = np.concatenate([np.array(c) for _, c in cells])
        self.offset = np.concatenate([[0], np.cumsum([len(c) for _, c in cells])])
        self.point_data, self.cell_data = FakeData(point_data), FakeData(cell_data)
        self.active_scalars_name = None


class FakeImage:
    """The attributes of a pyvista.ImageData that tetkit reads."""

    def __init__(self, dims):
        self.dimensions = dims
        x, y, z = np.meshgrid(*[np.arange(d, dtype=float) for d in dims], indexing="ij")
        self.points = np.stack([x.ravel(order="F"), y.ravel(order="F"), z.ravel(order="F")], axis=1)
        self.point_data = FakeData({"s": self.points[:, 0] + 2 * self.points[:, 1]})
        self.cell_data = FakeData()
        self.active_scalars_name = "s"


def test_from_pyvista_shaped_objects():
    pts, _ = hex_and_wedge()
    grid = FakeUnstructured(pts, [(12, [0, 1, 2, 3, 4, 5, 6, 7]), (13, [4, 5, 8, 7, 6, 9]), (5, [0, 1, 2])],
                            {"t": pts[:, 2]}, {"c": np.array([1.0, 2.0, 3.0])})
    b = tetkit.from_pyvista(grid)
    assert b.num_points == 10 and b.scalar_name == "t" and "without volume" in " ".join(b.findings)
    img = tetkit.from_pyvista(FakeImage((4, 3, 2)))
    assert (img.num_points, img.num_tets) == (24, 6 * 5)
    assert img.scalar_range == (0.0, 7.0)
    bad = FakeUnstructured(pts, [(12, [0, 1, 2, 3, 4, 5, 6, 70])], {"t": pts[:, 2]}, {})
    with pytest.raises(tetkit.TetkitError) as e:
        tetkit.from_pyvista(bad)
    assert str(e.value).startswith("connectivity") and "point 70" in str(e.value)
    poly = FakeUnstructured(pts, [(42, [0, 1, 2, 3])], {"t": pts[:, 2]}, {})
    with pytest.raises(tetkit.TetkitError) as e:
        tetkit.from_pyvista(poly)
    assert "VTK type 42" in str(e.value)
    with pytest.raises(tetkit.TetkitError):
        tetkit.from_pyvista(object())


def test_lagrange_and_bezier_cells_from_arrays():
    # A 27-node Lagrange hexahedron (VTK 72) in VTK's node order: cut at all
    # its nodes (8 sub-hexahedra, 48 tets); as a Bezier one (79) evaluated
    # at its lattice (control points on the lattice: the same points) and
    # cut there too; rational with a point field named RationalWeights.
    lattice = [(0, 0, 0), (2, 0, 0), (2, 2, 0), (0, 2, 0), (0, 0, 2), (2, 0, 2), (2, 2, 2), (0, 2, 2),
               (1, 0, 0), (2, 1, 0), (1, 2, 0), (0, 1, 0), (1, 0, 2), (2, 1, 2), (1, 2, 2), (0, 1, 2),
               (0, 0, 1), (2, 0, 1), (2, 2, 1), (0, 2, 1), (0, 1, 1), (2, 1, 1), (1, 0, 1), (1, 2, 1),
               (1, 1, 0), (1, 1, 2), (1, 1, 1)]
    pts = np.array(lattice, dtype=float) / 2.0
    lagrange = tetkit.from_pyvista(FakeUnstructured(pts, [(72, list(range(27)))], {"t": pts[:, 0]}, {}))
    assert lagrange.num_tets == 48
    bezier = tetkit.from_pyvista(FakeUnstructured(pts, [(79, list(range(27)))], {"t": pts[:, 0]}, {}))
    assert bezier.num_tets == 48 and "evaluated 1 Bezier" in " ".join(bezier.findings).replace("é", "e")
    assert bezier.scalar_range == (0.0, 1.0)
    weights = {"t": pts[:, 0], "RationalWeights": np.ones(27)}
    rational = tetkit.from_pyvista(FakeUnstructured(pts, [(79, list(range(27)))], weights, {}), scalar="t")
    assert rational.num_tets == 48 and "rational" in " ".join(rational.findings)
    meshio = pytest.importorskip("meshio")
    m = meshio.Mesh(pts, [("VTK_LAGRANGE_HEXAHEDRON", np.arange(27).reshape(1, 27))], point_data={"t": pts[:, 0]})
    assert tetkit.from_meshio(m).num_tets == 48
    wrong = FakeUnstructured(pts, [(72, list(range(26)))], {"t": pts[:, 0]}, {})
    with pytest.raises(tetkit.TetkitError) as e:
        tetkit.from_pyvista(wrong)
    assert "VTK type 72" in str(e.value) and "26 nodes" in str(e.value)


def test_from_real_pyvista():
    pv = pytest.importorskip("pyvista")
    img = pv.ImageData(dimensions=(5, 4, 3))
    img.point_data["s"] = np.arange(img.n_points, dtype=float)
    b = tetkit.from_pyvista(img)
    assert (b.num_points, b.num_tets) == (60, 4 * 3 * 2 * 5)
    u = tetkit.from_pyvista(img.cast_to_unstructured_grid())
    assert u.num_points == 60 and u.scalar_range == (0.0, 59.0)


def test_histogram_gradients_limits():
    b = bluntfin()
    h = b.histogram(bins=(64, 32))
    assert h["scalar"].shape == (64,) and h["joint"].shape == (32, 64)
    assert h["scalar_edges"].shape == (65,) and h["gradient_edges"].shape == (33,)
    # Every volume lands in a bin or off the axes.
    total = h["scalar"].sum() + h["scalar_below"] + h["scalar_above"]
    assert abs(total - h["total_volume"]) <= 1e-9 * h["total_volume"]
    assert abs(h["joint"].sum() + h["joint_outside"] - h["total_volume"]) <= 1e-9 * h["total_volume"]
    g = b.gradients()
    assert g.shape == (b.num_points, 3) and np.isfinite(g).all()
    with pytest.raises(tetkit.TetkitError):
        b.gradients("nope")
    lim = b.limits()
    assert lim["max_cell_scalar_range"] > 0 and lim["frequency_limit"] > 0
    with pytest.raises(tetkit.TetkitError):
        b.histogram(bins=(0, 8))


def test_bake_renders_and_saves_what_tetview_reads(tmp_path):
    b = bluntfin()
    t = tetkit.bake(b, tf=PEAKS)
    assert t.method == "table3d" and t.memory_bytes > 0
    c = t.certificate
    assert c["certified"] and c["max_error"] <= c["target"], c
    with_table = tetkit.render(b, table=t, size=(48, 40), azimuth=20)
    baked_now = tetkit.render(b, tf=PEAKS, size=(48, 40), azimuth=20)
    assert np.asarray(with_table).tobytes() == np.asarray(baked_now).tobytes()
    path = tmp_path / "peaks.tetl"
    t.save(str(path))
    from_file = tetkit.render(b, lut=path, size=(48, 40), azimuth=20)
    assert np.asarray(from_file).tobytes() == np.asarray(baked_now).tobytes()
    with pytest.raises(tetkit.TetkitError):
        tetkit.render(b, table="not a table", size=(8, 8))


@pytest.mark.filterwarnings("ignore::pytest.PytestUnraisableExceptionWarning")
def test_progress_callbacks_and_interact():
    b = bluntfin()
    seen = []
    tetkit.render(b, tf=PEAKS, size=(64, 64), progress=lambda done, total: seen.append((done, total)))
    assert seen and seen[-1][0] == seen[-1][1] and all(d <= t for d, t in seen), seen
    assert len(seen) <= 102
    # Regression: two workers once delivered (16, 16) then (12, 16).
    assert all(a[0] < b[0] for a, b in zip(seen, seen[1:])), seen
    ref_seen = []
    tetkit.reference(b, tf=PEAKS, size=(16, 16), progress=lambda d, t: ref_seen.append(d))
    assert ref_seen
    # An exception in the callback does not stop the render.
    def boom(done, total):
        raise RuntimeError("callback failed")
    img = tetkit.render(b, tf=PEAKS, size=(16, 16), progress=boom)
    assert img.shape == (16, 16, 4)
    tetkit.render(b, tf=PEAKS, size=(16, 16), progress=True)  # tqdm where installed, else nothing
    try:
        import ipywidgets  # noqa: F401
    except ImportError:
        with pytest.raises(ImportError) as e:
            tetkit.interact(b, tf=PEAKS)
        assert "pip install ipywidgets" in str(e.value)
    else:
        ui = tetkit.interact(b, tf=PEAKS, size=(32, 32))
        assert ui is not None


def test_interact_without_ipywidgets_says_what_to_install(monkeypatch):
    # A None entry in sys.modules makes `import ipywidgets` raise ImportError,
    # as on a machine without it (CI installs it, so simulate the absence).
    monkeypatch.setitem(__import__("sys").modules, "ipywidgets", None)
    with pytest.raises(ImportError) as e:
        tetkit.interact(bluntfin(), tf=PEAKS)
    assert "pip install ipywidgets" in str(e.value)


def test_histogram_png_and_notebook_summary(tmp_path):
    b = bluntfin()
    out = tmp_path / "hist.png"
    png = b.histogram_png(str(out), bins=(64, 32), units="kg/m^3", length_units="m")
    assert png[:8] == b"\x89PNG\r\n\x1a\n" and out.read_bytes() == png
    width, height = int.from_bytes(png[16:20], "big"), int.from_bytes(png[20:24], "big")
    assert (width, height) == (900, 776), (width, height)  # the figure of `tetprep hist`
    assert b.histogram_png(log=False) != b.histogram_png()
    with pytest.raises(tetkit.TetkitIOError):
        b.histogram_png(str(tmp_path / "no-such-dir" / "h.png"))
    with pytest.raises(tetkit.TetkitError):
        b.histogram_png(bins=(0, 8))
    html = b._repr_html_()
    assert f"<td>{b.num_tets}</td>" in html and "density" in html and "<table>" in html
