"""Lagrange test meshes written by VTK itself (vtkCellTypeSource), bent onto a
quarter of a cylindrical shell (radius 1..2, 90 degrees, height 1; volume
3*pi/4), with a point field r^2. Prints, per file, the volume of VTK's own
linear tessellation of the cells (vtkCell.Triangulate) and of their corners."""
import vtk, math, sys
out = sys.argv[1]

def bend(ug, sx, sy):
    pts = ug.GetPoints()
    f = vtk.vtkDoubleArray(); f.SetName("r2")
    for i in range(pts.GetNumberOfPoints()):
        x, y, z = pts.GetPoint(i)
        r = 1.0 + x / sx; t = (y / sy) * math.pi / 2
        pts.SetPoint(i, r * math.cos(t), r * math.sin(t), z)
        f.InsertNextValue(r * r)
    ug.GetPointData().AddArray(f)
    ug.GetPointData().SetActiveScalars("r2")

def tet_volume(p):
    a = [p[1][k] - p[0][k] for k in range(3)]; b = [p[2][k] - p[0][k] for k in range(3)]; c = [p[3][k] - p[0][k] for k in range(3)]
    return (a[0]*(b[1]*c[2]-b[2]*c[1]) - a[1]*(b[0]*c[2]-b[2]*c[0]) + a[2]*(b[0]*c[1]-b[1]*c[0])) / 6

def volumes(ug):
    tess = 0.0; ntets = 0
    for c in range(ug.GetNumberOfCells()):
        cell = ug.GetCell(c)
        ids = vtk.vtkIdList(); pts = vtk.vtkPoints()
        cell.Triangulate(0, ids, pts)
        for t in range(pts.GetNumberOfPoints() // 4):
            tess += abs(tet_volume([pts.GetPoint(4 * t + k) for k in range(4)])); ntets += 1
    return tess, ntets

def write(ug, name):
    w = vtk.vtkXMLUnstructuredGridWriter(); w.SetFileName(out + "/" + name); w.SetInputData(ug)
    w.SetCompressorTypeToZLib(); w.Write()

def source(ctype, order, dims):
    s = vtk.vtkCellTypeSource(); s.SetCellType(ctype); s.SetCellOrder(order); s.SetBlocksDimensions(*dims); s.Update()
    ug = vtk.vtkUnstructuredGrid(); ug.DeepCopy(s.GetOutput())
    return ug

print("exact volume", 3 * math.pi / 4)
for name, ctype, order in [("lagrange_hex_o3.vtu", 72, 3), ("lagrange_tet_o3.vtu", 71, 3), ("lagrange_wedge_o4.vtu", 73, 4), ("lagrange_hex_o1.vtu", 72, 1)]:
    ug = source(ctype, order, (2, 2, 1))
    for a in [ug.GetPointData().GetArrayName(i) for i in range(ug.GetPointData().GetNumberOfArrays())]:
        ug.GetPointData().RemoveArray(a)
    for a in [ug.GetCellData().GetArrayName(i) for i in range(ug.GetCellData().GetNumberOfArrays())]:
        ug.GetCellData().RemoveArray(a)
    bend(ug, 2.0, 2.0)
    tess, n = volumes(ug)
    write(ug, name)
    if name == "lagrange_tet_o3.vtu":
        w = vtk.vtkUnstructuredGridWriter(); w.SetFileName(out + "/lagrange_tet_o3.vtk"); w.SetInputData(ug); w.SetFileTypeToBinary(); w.Write()
    print(name, "cells", ug.GetNumberOfCells(), "points", ug.GetNumberOfPoints(), "VTK tessellation: tets", n, "volume %.12f" % tess)

# One hexahedron of orders (2, 3, 1) given by HigherOrderDegrees, nodes at its parameter lattice, bent.
o = (2, 3, 1)
ug = vtk.vtkUnstructuredGrid(); pts = vtk.vtkPoints()
npts = (o[0] + 1) * (o[1] + 1) * (o[2] + 1)
probe = vtk.vtkLagrangeHexahedron()
probe.GetPointIds().SetNumberOfIds(npts); probe.GetPoints().SetNumberOfPoints(npts)
for i in range(npts): probe.GetPointIds().SetId(i, i); probe.GetPoints().SetPoint(i, 0, 0, 0)
probe.SetOrder(*o)
pc = probe.GetParametricCoords()
for i in range(npts): pts.InsertNextPoint(pc[3 * i], pc[3 * i + 1], pc[3 * i + 2])
ug.SetPoints(pts)
ids = vtk.vtkIdList()
for i in range(npts): ids.InsertNextId(i)
ug.InsertNextCell(72, ids)
deg = vtk.vtkIntArray(); deg.SetName("HigherOrderDegrees"); deg.SetNumberOfComponents(3); deg.InsertNextTuple3(*o)
ug.GetCellData().SetHigherOrderDegrees(deg)
bend(ug, 1.0, 1.0)
tess, n = volumes(ug)
write(ug, "lagrange_hex_231.vtu")
print("lagrange_hex_231.vtu cells 1 points", npts, "VTK tessellation: tets", n, "volume %.12f" % tess)
