"""Writes vtk_lagrange_nodes.txt: where VTK puts each node of its Lagrange
volume cells, as integer lattice points (parametric coordinate x order),
read from VTK's own cells (`GetParametricCoords`). Run with VTK's Python
package (tested with vtk 9.7.2 from PyPI):

    python vtk_lagrange_nodes.py > vtk_lagrange_nodes.txt
"""
import vtk


def lattice(vtk_type, npts, orders):
    ug = vtk.vtkUnstructuredGrid()
    pts = vtk.vtkPoints()
    for i in range(npts):
        pts.InsertNextPoint(i, 0, 0)
    ug.SetPoints(pts)
    ids = vtk.vtkIdList()
    for i in range(npts):
        ids.InsertNextId(i)
    ug.InsertNextCell(vtk_type, ids)
    degrees = vtk.vtkIntArray()
    degrees.SetName("HigherOrderDegrees")
    degrees.SetNumberOfComponents(3)
    degrees.InsertNextTuple3(*orders)
    ug.GetCellData().SetHigherOrderDegrees(degrees)
    pc = ug.GetCell(0).GetParametricCoords()
    return [[int(round(pc[3 * i + k] * orders[k])) for k in range(3)] for i in range(npts)]


print("# vtk %s: type orders: lattice points in node order" % vtk.vtkVersion.GetVTKVersion())
for n in range(1, 9):
    print("71 %d %d %d:" % (n, n, n), " ".join("%d,%d,%d" % tuple(p) for p in lattice(71, (n + 1) * (n + 2) * (n + 3) // 6, (n, n, n))))
for o in [(1, 1, 1), (2, 2, 2), (3, 3, 3), (4, 4, 4), (2, 3, 1), (3, 1, 2), (1, 4, 2), (5, 2, 3)]:
    npts = (o[0] + 1) * (o[1] + 1) * (o[2] + 1)
    print("72 %d %d %d:" % o, " ".join("%d,%d,%d" % tuple(p) for p in lattice(72, npts, o)))
for (n, m) in [(1, 1), (2, 2), (3, 3), (4, 4), (5, 5), (6, 6), (7, 7), (3, 1), (2, 4), (5, 2), (1, 3)]:
    npts = (n + 1) * (n + 2) // 2 * (m + 1)
    print("73 %d %d %d:" % (n, n, m), " ".join("%d,%d,%d" % tuple(p) for p in lattice(73, npts, (n, n, m))))
