"""Writes small.exo: a hand-made Exodus II results file, written with SciPy's
netCDF classic writer (scipy.io.netcdf_file, independent of tetkit's reader)
in the layout the SEACAS Exodus library uses. Run: python3 make_small.py
(needs numpy and scipy). Contents, used by crates/tet_io/tests/exodus.rs:

- 10 nodes in separate coordx/coordy/coordz: a unit cube (nodes 1-8), a
  pyramid apex above it (node 9, z = 2) and a spare node 10 used only by the
  shell block;
- block id 10: one HEX8 (the cube); block id 20: one PYRAMID5 on the cube's
  top face; block id 30: one SHELL4 (skipped by tetkit with a note);
- two time steps, t = 0.5 and 1.5;
- nodal variables T (node number times the step's time) and P (minus that),
  in vals_nod_var1 / vals_nod_var2;
- one element variable rho, stored for block 10 only (elem_var_tab 1 0 0):
  7.0 at step 0, 8.0 at step 1.
"""
import numpy as np
from scipy.io import netcdf_file


def chars(rows, width):
    a = np.zeros((len(rows), width), dtype="S1")
    for i, r in enumerate(rows):
        for j, ch in enumerate(r.encode()):
            a[i, j] = bytes([ch])
    return a


f = netcdf_file("small.exo", "w", version=2)
f.api_version = np.float32(8.0)
f.version = np.float32(8.0)
f.floating_point_word_size = np.int32(8)
f.file_size = np.int32(1)
f.title = b"tetkit small Exodus II test file"
dims = dict(len_string=33, len_name=33, len_line=81, four=4, num_dim=3, num_nodes=10,
            num_elem=3, num_el_blk=3, num_el_in_blk1=1, num_nod_per_el1=8,
            num_el_in_blk2=1, num_nod_per_el2=5, num_el_in_blk3=1, num_nod_per_el3=4,
            num_nod_var=2, num_elem_var=1)
# SciPy wants the unlimited (record) dimension first; SEACAS puts it after
# the string lengths. The reader takes it anywhere.
f.createDimension("time_step", None)
for k, v in dims.items():
    f.createDimension(k, v)
t = f.createVariable("time_whole", "d", ("time_step",))
t[:] = [0.5, 1.5]
ebs = f.createVariable("eb_status", "i", ("num_el_blk",))
ebs[:] = [1, 1, 1]
ebp = f.createVariable("eb_prop1", "i", ("num_el_blk",))
ebp[:] = [10, 20, 30]
ebp.name = b"ID"
xyz = [(0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0), (0, 0, 1), (1, 0, 1), (1, 1, 1), (0, 1, 1),
       (0.5, 0.5, 2), (3, 3, 3)]
for k, n in enumerate("xyz"):
    c = f.createVariable("coord" + n, "d", ("num_nodes",))
    c[:] = [p[k] for p in xyz]
f.createVariable("coor_names", "c", ("num_dim", "len_name"))[:] = chars(["x", "y", "z"], 33)
for i, (typ, conn) in enumerate([("HEX8", [1, 2, 3, 4, 5, 6, 7, 8]), ("PYRAMID5", [5, 6, 7, 8, 9]),
                                 ("SHELL4", [1, 2, 10, 4])], start=1):
    v = f.createVariable(f"connect{i}", "i", (f"num_el_in_blk{i}", f"num_nod_per_el{i}"))
    v[:] = [conn]
    v.elem_type = typ.encode()
f.createVariable("name_nod_var", "c", ("num_nod_var", "len_name"))[:] = chars(["T", "P"], 33)
f.createVariable("name_elem_var", "c", ("num_elem_var", "len_name"))[:] = chars(["rho"], 33)
tab = f.createVariable("elem_var_tab", "i", ("num_el_blk", "num_elem_var"))
tab[:] = [[1], [0], [0]]
node = np.arange(1, 11, dtype=float)
T = f.createVariable("vals_nod_var1", "d", ("time_step", "num_nodes"))
P = f.createVariable("vals_nod_var2", "d", ("time_step", "num_nodes"))
T[:] = [node * 0.5, node * 1.5]
P[:] = [-node * 0.5, -node * 1.5]
rho = f.createVariable("vals_elem_var1eb1", "d", ("time_step", "num_el_in_blk1"))
rho[:] = [[7.0], [8.0]]
f.close()
