"""Writes prismquarter_o3_41_ascii.msh: a quarter of a unit disk, meshed with
triangles of size 0.3 and extruded by 1 in two layers of prisms, raised to
complete third order (40-node prisms, curved along the arc); Gmsh 4.1 ASCII.
Exact volume pi/4. Run with Gmsh's Python package (gmsh 4.15.2 from PyPI) in
this directory:

    python prismquarter_o3.py prismquarter_o3_41_ascii.msh
"""
import gmsh, sys
gmsh.initialize(); gmsh.option.setNumber("General.Terminal", 0)
gmsh.option.setNumber("Mesh.MshFileVersion", 4.1)
g = gmsh.model.geo
o, a, b = g.addPoint(0, 0, 0, 0.3), g.addPoint(1, 0, 0, 0.3), g.addPoint(0, 1, 0, 0.3)
l1, arc, l2 = g.addLine(o, a), g.addCircleArc(a, o, b), g.addLine(b, o)
s = g.addPlaneSurface([g.addCurveLoop([l1, arc, l2])])
g.extrude([(2, s)], 0, 0, 1, [2], recombine=True)
g.synchronize()
gmsh.model.mesh.generate(3)
gmsh.model.mesh.setOrder(3)
gmsh.write(sys.argv[1])
