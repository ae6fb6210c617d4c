"""A large Exodus II file for timing the readers (not a test input): an n^3 grid of HEX8, one nodal variable at 3 steps, written with SciPy's netCDF classic writer. Run: python3 make_big.py N OUT.exo (needs numpy and scipy)."""
import numpy as np, sys
from scipy.io import netcdf_file
n = int(sys.argv[1]); path = sys.argv[2]
m = n + 1
x, y, z = np.meshgrid(np.arange(m, dtype=float), np.arange(m, dtype=float), np.arange(m, dtype=float), indexing="ij")
x, y, z = x.ravel(order="F"), y.ravel(order="F"), z.ravel(order="F")
nid = lambda i, j, k: i + m * (j + m * k) + 1
i, j, k = np.meshgrid(np.arange(n), np.arange(n), np.arange(n), indexing="ij")
i, j, k = i.ravel(), j.ravel(), k.ravel()
conn = np.stack([nid(i, j, k), nid(i+1, j, k), nid(i+1, j+1, k), nid(i, j+1, k),
                 nid(i, j, k+1), nid(i+1, j, k+1), nid(i+1, j+1, k+1), nid(i, j+1, k+1)], axis=1).astype(np.int32)
f = netcdf_file(path, "w", version=2)
f.api_version = np.float32(8.0); f.version = np.float32(8.0); f.floating_point_word_size = np.int32(8)
f.createDimension("time_step", None); f.createDimension("len_string", 33); f.createDimension("num_dim", 3)
f.createDimension("num_nodes", m**3); f.createDimension("num_elem", n**3); f.createDimension("num_el_blk", 1)
f.createDimension("num_el_in_blk1", n**3); f.createDimension("num_nod_per_el1", 8); f.createDimension("num_nod_var", 1)
t = f.createVariable("time_whole", "f8", ("time_step",))
v = f.createVariable("eb_prop1", "i4", ("num_el_blk",)); v[:] = [1]
for name, a in (("coordx", x), ("coordy", y), ("coordz", z)):
    c = f.createVariable(name, "f8", ("num_nodes",)); c[:] = a
c = f.createVariable("connect1", "i4", ("num_el_in_blk1", "num_nod_per_el1")); c[:] = conn; c.elem_type = b"HEX8"
nm = f.createVariable("name_nod_var", "S1", ("num_nod_var", "len_string"))
row = np.zeros(33, dtype="S1"); row[0] = b"T"; nm[0, :] = row
vv = f.createVariable("vals_nod_var1", "f8", ("time_step", "num_nodes"))
for s in range(3):
    t[s] = float(s)
    vv[s, :] = np.sin(0.1 * x + s) * np.cos(0.07 * y) + 0.01 * z
f.close()
