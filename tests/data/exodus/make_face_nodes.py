"""Writes face_nodes.exo: Exodus II elements with face nodes but no body
node (TETRA14, WEDGE20, PYRAMID18) and with face nodes only (TETRA8), in the
node orders of SEACAS's Ioss element topologies, written with SciPy's netCDF
classic writer (independent of tetkit's reader). Run: python3
make_face_nodes.py (needs numpy and scipy). Contents, used by
crates/tet_io/tests/exodus.rs:

- block 1, TETRA14: a unit cube at the origin cut into six tetrahedra
  around its diagonal 0-6 (Kuhn), nodes shared between neighbours;
- block 2, TETRA8: the same cube moved by 2 along x;
- block 3, WEDGE20: two wedges filling the unit cube moved by 4 along x;
- block 4, PYRAMID18: six pyramids filling the unit cube moved by 6 along x
  (apex at its centre);
- straight-sided elements, so every block's volume is 1;
- nodal variable T = 2x - 3y + 0.5z + 7 at t = 0 and twice that at t = 1.
"""
import numpy as np
from scipy.io import netcdf_file

nodes, index = [], {}


def node(p):
    key = tuple(round(c, 9) for c in p)
    if key not in index:
        nodes.append(p)
        index[key] = len(nodes)
    return index[key]


def mean(c, ps):
    return tuple(sum(c[i][k] for i in ps) / len(ps) for k in range(3))


def element(c, extra):
    return [node(p) for p in c] + [node(mean(c, ps)) for ps in extra]


CUBE = [(0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0), (0, 0, 1), (1, 0, 1), (1, 1, 1), (0, 1, 1)]
KUHN = [(0, 1, 2, 6), (0, 2, 3, 6), (0, 3, 7, 6), (0, 7, 4, 6), (0, 4, 5, 6), (0, 5, 1, 6)]
TET_EDGES = [(0, 1), (1, 2), (2, 0), (0, 3), (1, 3), (2, 3)]
TET14_FACES = [(0, 2, 1), (1, 2, 3), (0, 3, 2), (0, 1, 3)]
TET8_FACES = [(0, 1, 3), (1, 2, 3), (0, 2, 1), (0, 3, 2)]
WEDGE_EDGES = [(0, 1), (1, 2), (2, 0), (0, 3), (1, 4), (2, 5), (3, 4), (4, 5), (5, 3)]
WEDGE20_FACES = [(0, 2, 1), (3, 4, 5), (1, 2, 5, 4), (0, 3, 5, 2), (0, 1, 4, 3)]
PYR_EDGES = [(0, 1), (1, 2), (2, 3), (3, 0), (0, 4), (1, 4), (2, 4), (3, 4)]
PYR18_FACES = [(0, 1, 2, 3), (0, 1, 4), (1, 2, 4), (2, 3, 4), (3, 0, 4)]


def cube(dx):
    return [(x + dx, y, z) for x, y, z in CUBE]


def tets(dx, faces, edges):
    c = cube(dx)
    return [element([c[i] for i in t], edges + faces) for t in KUHN]


blocks = [
    ("TETRA14", tets(0, TET14_FACES, TET_EDGES)),
    ("TETRA8", tets(2, TET8_FACES, [])),
]
c = cube(4)
wedges = [[c[0], c[1], c[3], c[4], c[5], c[7]], [c[1], c[2], c[3], c[5], c[6], c[7]]]
blocks.append(("WEDGE20", [element(w, WEDGE_EDGES + WEDGE20_FACES) for w in wedges]))
c = cube(6)
apex = (6.5, 0.5, 0.5)
# Each face of the cube as a base seen from outside, apex inside: bases
# ordered so that the apex is on the side the right-hand rule points to.
faces = [(0, 1, 2, 3), (4, 7, 6, 5), (0, 4, 5, 1), (1, 5, 6, 2), (2, 6, 7, 3), (3, 7, 4, 0)]
blocks.append(("PYRAMID18", [element([c[i] for i in f] + [apex], PYR_EDGES + PYR18_FACES) for f in faces]))

xyz = np.array(nodes, dtype=float)
T = 2 * xyz[:, 0] - 3 * xyz[:, 1] + 0.5 * xyz[:, 2] + 7


def chars(rows, width):
    a = np.zeros((len(rows), width), dtype="S1")
    for i, r in enumerate(rows):
        for j, ch in enumerate(r.encode()):
            a[i, j] = bytes([ch])
    return a


f = netcdf_file("face_nodes.exo", "w", version=2)
f.api_version = np.float32(8.0)
f.version = np.float32(8.0)
f.floating_point_word_size = np.int32(8)
f.file_size = np.int32(1)
f.title = b"tetkit Exodus II elements with face nodes"
f.createDimension("time_step", None)
dims = dict(len_string=33, len_name=33, len_line=81, four=4, num_dim=3, num_nodes=len(nodes),
            num_elem=sum(len(b[1]) for b in blocks), num_el_blk=len(blocks), num_nod_var=1)
for i, (typ, conn) in enumerate(blocks, start=1):
    dims[f"num_el_in_blk{i}"] = len(conn)
    dims[f"num_nod_per_el{i}"] = len(conn[0])
for k, v in dims.items():
    f.createDimension(k, v)
t = f.createVariable("time_whole", "d", ("time_step",))
t[:] = [0.0, 1.0]
f.createVariable("eb_status", "i", ("num_el_blk",))[:] = [1] * len(blocks)
ebp = f.createVariable("eb_prop1", "i", ("num_el_blk",))
ebp[:] = list(range(1, len(blocks) + 1))
ebp.name = b"ID"
for k, n in enumerate("xyz"):
    f.createVariable("coord" + n, "d", ("num_nodes",))[:] = xyz[:, k]
f.createVariable("coor_names", "c", ("num_dim", "len_name"))[:] = chars(["x", "y", "z"], 33)
for i, (typ, conn) in enumerate(blocks, start=1):
    v = f.createVariable(f"connect{i}", "i", (f"num_el_in_blk{i}", f"num_nod_per_el{i}"))
    v[:] = conn
    v.elem_type = typ.encode()
f.createVariable("name_nod_var", "c", ("num_nod_var", "len_name"))[:] = chars(["T"], 33)
f.createVariable("vals_nod_var1", "d", ("time_step", "num_nodes"))[:] = [T, 2 * T]
f.close()
print(len(nodes), "nodes;", [(b[0], len(b[1])) for b in blocks])
