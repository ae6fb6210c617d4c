"""Writes gmsh_nodes.txt: where Gmsh puts each node of its complete
tetrahedra (orders 1-10) and hexahedra (1-9), as integer lattice points
(the reference element's coordinates mapped onto VTK's parameter cell,
times the order), read from Gmsh's own `getElementProperties`. Run with
Gmsh's Python package (tested with gmsh 4.15.2 from PyPI):

    python gmsh_nodes.py > gmsh_nodes.txt

(Gmsh 4.15 gives no reference nodes for prisms of order 3 and above.)
"""
import gmsh, sys
gmsh.initialize(); gmsh.option.setNumber("General.Terminal", 0)
out = {}
for fam, types in (("tet", [4, 11, 29, 30, 31, 71, 72, 73, 74, 75]), ("hex", [5, 12, 92, 93, 94, 95, 96, 97, 98]),):
    for t in types:
        name, dim, order, nn, coords, npri = gmsh.model.mesh.getElementProperties(t)
        pts = []
        for k in range(nn):
            x, y, z = coords[3*k:3*k+3]
            if fam == "tet": p = (x*order, y*order, z*order)
            elif fam == "hex": p = ((x+1)/2*order, (y+1)/2*order, (z+1)/2*order)
            else: p = (x*order, y*order, (z+1)/2*order)
            q = tuple(int(round(c)) for c in p)
            assert all(abs(a-b) < 1e-6 for a, b in zip(p, q)), (t, p)
            pts.append(q)
        print(fam, t, order, " ".join("%d,%d,%d" % p for p in pts))
