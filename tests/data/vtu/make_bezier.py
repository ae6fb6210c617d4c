"""Bezier volume cells for tet_io's tests, and VTK's own evaluation of them
at their lattice nodes (positions and the point scalar `s`).

Run as `python make_bezier.py OUTDIR NODES_TXT` with VTK's Python package:
writes OUTDIR/bezier_cells.vtu (polynomial cells of several types and
orders, two hexahedra sharing a face), OUTDIR/bezier_cells.vtk (its cells of
equal orders, binary legacy VTK) and OUTDIR/bezier_rational.vtu (a
rational quadratic hexahedron that is exactly a quarter of a cylindrical
shell, radius 1..2, beside a rational tetrahedron) and, per cell and node,
VTK's EvaluateLocation at the node's parametric coordinates and the scalar
interpolated with VTK's weights, one line each:
`file cell node x y z s`."""
import math, random, sys
import vtk
random.seed(7)

def lattice(vtk_type, npts, degrees=None):
    """Parametric coords of a higher-order cell's nodes, as VTK orders them."""
    ug = vtk.vtkUnstructuredGrid()
    pts = vtk.vtkPoints(); pts.SetNumberOfPoints(npts)
    for i in range(npts): pts.SetPoint(i, 0, 0, 0)
    ug.SetPoints(pts)
    ug.InsertNextCell(vtk_type, npts, list(range(npts)))
    if degrees:
        d = vtk.vtkIntArray(); d.SetName("HigherOrderDegrees"); d.SetNumberOfComponents(3)
        d.InsertNextTuple3(*degrees); ug.GetCellData().SetHigherOrderDegrees(d)
    c = ug.GetCell(0)
    pc = c.GetParametricCoords()
    return [(pc[3*i], pc[3*i+1], pc[3*i+2]) for i in range(npts)]

def build(cells, rational, path, dump):
    """cells: list of (vtk_type, npts, degrees or None, map(r,s,t)->xyz, shared)"""
    ug = vtk.vtkUnstructuredGrid()
    pts = vtk.vtkPoints(); pts.SetDataTypeToDouble()
    key = {}
    conn = []
    for (ty, npts, deg, f) in cells:
        ids = []
        for p in lattice(ty, npts, deg):
            x = f(*p)
            k = tuple(round(v, 9) for v in x)
            if k not in key:
                key[k] = pts.InsertNextPoint(*x)
            ids.append(key[k])
        conn.append((ty, ids))
    ug.SetPoints(pts)
    for ty, ids in conn: ug.InsertNextCell(ty, len(ids), ids)
    if any(d for (_, _, d, _) in cells):
        d = vtk.vtkIntArray(); d.SetName("HigherOrderDegrees"); d.SetNumberOfComponents(3)
        for (_, _, deg, _) in cells: d.InsertNextTuple3(*(deg or (0, 0, 0)))
        ug.GetCellData().SetHigherOrderDegrees(d)
        ug.GetCellData().AddArray(d)
    s = vtk.vtkDoubleArray(); s.SetName("s")
    n = pts.GetNumberOfPoints()
    for i in range(n):
        x = pts.GetPoint(i)
        s.InsertNextValue(math.sin(1.3 * x[0]) + x[1] * x[2] + 0.2 * random.random())
    ug.GetPointData().AddArray(s); ug.GetPointData().SetActiveScalars("s")
    if rational:
        w = vtk.vtkDoubleArray(); w.SetName("RationalWeights")
        for i in range(n): w.InsertNextValue(rational(i, pts.GetPoint(i)))
        ug.GetPointData().SetRationalWeights(w)
        ug.GetPointData().AddArray(w)
    if path.endswith(".vtk"):
        wr = vtk.vtkUnstructuredGridWriter(); wr.SetFileTypeToBinary()
    else:
        wr = vtk.vtkXMLUnstructuredGridWriter(); wr.SetDataModeToAscii()
    wr.SetFileName(path); wr.SetInputData(ug); wr.Write()
    # VTK's evaluation at each cell's lattice nodes.
    for ci in range(ug.GetNumberOfCells()):
        c = ug.GetCell(ci)
        m = c.GetNumberOfPoints()
        pc = c.GetParametricCoords()
        for i in range(m):
            x = [0.0, 0.0, 0.0]
            wv = [0.0] * m
            sub = vtk.reference(0)
            c.EvaluateLocation(sub, [pc[3*i], pc[3*i+1], pc[3*i+2]], x, wv)
            val = sum(wv[j] * s.GetValue(c.GetPointId(j)) for j in range(m))
            dump.write(f"{path.split('/')[-1]} {ci} {i} {x[0]:.17g} {x[1]:.17g} {x[2]:.17g} {val:.17g}\n")

dump = open(sys.argv[2], "w")
out = sys.argv[1]
warp = lambda r, s, t: (r + 0.15 * math.sin(2.1 * s + 0.3) * (1 + t), s + 0.2 * r * r, t + 0.1 * math.cos(1.7 * r) * s)
shift = lambda f, dx: (lambda r, s, t: tuple(a + b for a, b in zip(f(r, s, t), dx)))
cells = [
    (78, 20, (3, 3, 3), shift(warp, (0, 0, 0))),                    # tetrahedron, order 3
    (79, 27, (2, 2, 2), shift(warp, (2, 0, 0))),                    # hexahedron, order 2
    (79, 27, (2, 2, 2), shift(lambda r, s, t: warp(r, s, t + 1), (2, 0, 0))),  # its neighbour above
    (79, 24, (1, 2, 3), shift(warp, (4, 0, 0))),               # hexahedron, orders (1, 2, 3)
    (80, 12, (2, 2, 1), shift(warp, (6, 0, 0))),               # wedge, orders (2, 2, 1)
    (80, 40, (3, 3, 3), shift(warp, (8, 0, 0))),                    # wedge, order 3
]
build(cells, None, f"{out}/bezier_cells.vtu", dump)
# Legacy files carry no HigherOrderDegrees: the cells of equal orders,
# without the degrees array.
build([(t, n, None, f) for (t, n, d, f) in cells if d is None or len(set(d)) == 1], None,
      f"{out}/bezier_cells.vtk", dump)
# A quarter of a thick cylinder shell as one rational quadratic hexahedron:
# radius 1 + r, angle s·90°, height t; weights √½ on the middle ring.
def ring(r, s, t):
    rad = 1.0 + r
    c = [(1, 0), (1, 1), (0, 1)][round(2 * s)]
    return (rad * c[0], rad * c[1], t)
cells = [(79, 27, None, ring), (78, 10, None, shift(warp, (3, 0, 0)))]
def weight(i, x):
    if x[0] < 2.5 and abs(x[0]) > 1e-9 and abs(x[1]) > 1e-9:
        return math.sqrt(0.5)
    return 1.0 + 0.3 * (i % 3) if x[0] > 2.5 else 1.0
build(cells, weight, f"{out}/bezier_rational.vtu", dump)
