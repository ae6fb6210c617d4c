"""Writes gmsh_nodes.txt: where Gmsh puts each node of its complete
tetrahedra (orders 1-10) and hexahedra (1-9), as integer lattice points
(the reference element's coordinates mapped onto VTK's parameter cell,
times the order), read from Gmsh's own `getElementProperties`. Run with
Gmsh's Python package (tested with gmsh 4.15.2 from PyPI):

    python gmsh_nodes.py > gmsh_nodes.txt

Gmsh 4.15 gives no reference nodes for prisms of order 3 and above: theirs
are read off a mesh it makes (one straight prism, raised to each order in
turn), mapped back onto the prism's parameter lattice by the inverse of
its affine map.
"""
import gmsh, sys
import numpy as np
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

for t in (7, 14, 118, 119, 120, 121, 122, 123, 124):
    # Pyramids on their sheared lattice: point (i, j, k) of layer k at
    # ((2i + k)/n - 1, (2j + k)/n - 1, k/n) of Gmsh's reference pyramid.
    name, dim, order, nn, coords, npri = gmsh.model.mesh.getElementProperties(t)
    pts = []
    for k in range(nn):
        x, y, z = coords[3 * k:3 * k + 3]
        p = ((x + 1 - z) / 2 * order, (y + 1 - z) / 2 * order, z * order)
        q = tuple(int(round(c)) for c in p)
        assert max(abs(a - b) for a, b in zip(p, q)) < 1e-6
        pts.append(q)
    print("pyramid", t, order, " ".join("%d,%d,%d" % p for p in pts))
gmsh.model.add("prism")
corners = [gmsh.model.geo.addPoint(*p, 1) for p in ((0, 0, 0), (1, 0, 0), (0, 1, 0))]
lines = [gmsh.model.geo.addLine(corners[a], corners[b]) for a, b in ((0, 1), (1, 2), (2, 0))]
surface = gmsh.model.geo.addPlaneSurface([gmsh.model.geo.addCurveLoop(lines)])
for l in lines:
    gmsh.model.geo.mesh.setTransfiniteCurve(l, 2)
gmsh.model.geo.mesh.setTransfiniteSurface(surface)
gmsh.model.geo.extrude([(2, surface)], 0, 0, 1, [1], recombine=True)
gmsh.model.geo.synchronize()
gmsh.model.mesh.generate(3)
for order in range(1, 7):
    gmsh.model.mesh.setOrder(order)
    (t,), (tags,), (nodes,) = gmsh.model.mesh.getElements(3)
    ntags, coords, _ = gmsh.model.mesh.getNodes()
    pos = {int(k): coords[3 * i:3 * i + 3] for i, k in enumerate(ntags)}
    P = np.array([pos[int(k)] for k in nodes.reshape(len(tags), -1)[0]])
    A = np.column_stack([P[1] - P[0], P[2] - P[0], P[3] - P[0]])
    L = np.linalg.solve(A, (P - P[0]).T).T * order
    assert np.abs(L - np.round(L)).max() < 1e-9
    print("prism", t, order, " ".join("%d,%d,%d" % tuple(int(round(v)) for v in row) for row in L))
