#!/usr/bin/env python3
"""Crops hurricane Isabel's wind speed (../shared/data/part2/series/isabel_0[2-5].vti,
WRF model data courtesy of NCAR and the U.S. NSF, via the TTK data archive) to a
24 x 24 x 10 box around the eye, and writes the four steps as VTK XML image data
(appended raw, UInt64 headers) with a ParaView .pvd and a .vti.series index.

usage: make_isabel_crop.py SRC_DIR OUT_DIR
"""
import json
import re
import struct
import sys
from pathlib import Path

I0, J0, K0 = 80, 59, 0
NI, NJ, NK = 24, 24, 10


def read_vti(path):
    data = path.read_bytes()
    head = data[: data.index(b"<AppendedData")].decode()
    ext = [int(v) for v in re.search(r'WholeExtent="([^"]+)"', head).group(1).split()]
    spacing = [float(v) for v in re.search(r'Spacing="([^"]+)"', head).group(1).split()]
    origin = [float(v) for v in re.search(r'Origin="([^"]+)"', head).group(1).split()]
    m = re.search(r'Name="velocityMag"[^>]*offset="\s*(\d+)', head)
    offset = int(m.group(1))
    start = data.index(b"_", data.index(b"<AppendedData")) + 1 + offset
    (nbytes,) = struct.unpack_from("<Q", data, start)
    nx, ny, nz = ext[1] - ext[0] + 1, ext[3] - ext[2] + 1, ext[5] - ext[4] + 1
    assert nbytes == 8 * nx * ny * nz, (nbytes, nx, ny, nz)
    values = struct.unpack_from(f"<{nx * ny * nz}d", data, start + 8)
    return (nx, ny, nz), spacing, origin, values


def write_vti(path, spacing, origin, values):
    org = [origin[0] + I0 * spacing[0], origin[1] + J0 * spacing[1], origin[2] + K0 * spacing[2]]
    header = (
        '<?xml version="1.0"?>\n'
        '<VTKFile type="ImageData" version="1.0" byte_order="LittleEndian" header_type="UInt64">\n'
        f'  <ImageData WholeExtent="0 {NI - 1} 0 {NJ - 1} 0 {NK - 1}" '
        f'Origin="{org[0]!r} {org[1]!r} {org[2]!r}" Spacing="{spacing[0]!r} {spacing[1]!r} {spacing[2]!r}">\n'
        f'    <Piece Extent="0 {NI - 1} 0 {NJ - 1} 0 {NK - 1}">\n'
        '      <PointData Scalars="velocityMag">\n'
        '        <DataArray type="Float64" Name="velocityMag" format="appended" offset="0"/>\n'
        "      </PointData>\n"
        "    </Piece>\n"
        "  </ImageData>\n"
        '  <AppendedData encoding="raw">\n   _'
    ).encode()
    body = struct.pack("<Q", 8 * len(values)) + struct.pack(f"<{len(values)}d", *values)
    path.write_bytes(header + body + b"\n  </AppendedData>\n</VTKFile>\n")


def main():
    src, out = Path(sys.argv[1]), Path(sys.argv[2])
    out.mkdir(parents=True, exist_ok=True)
    names = []
    for t in (2, 3, 4, 5):
        (nx, ny, nz), spacing, origin, v = read_vti(src / f"isabel_0{t}.vti")
        crop = [
            v[(K0 + k) * nx * ny + (J0 + j) * nx + (I0 + i)]
            for k in range(NK)
            for j in range(NJ)
            for i in range(NI)
        ]
        name = f"isabel_eye_0{t}.vti"
        write_vti(out / name, spacing, origin, crop)
        names.append((t, name))
    pvd = ['<?xml version="1.0"?><VTKFile type="Collection" version="0.1"><Collection>']
    pvd += [f'<DataSet timestep="{t}" part="0" file="{n}"/>' for t, n in names]
    pvd += ["</Collection></VTKFile>", ""]
    (out / "isabel_eye.pvd").write_text("\n".join(pvd))
    series = {"file-series-version": "1.0", "files": [{"name": n, "time": t} for t, n in names]}
    (out / "isabel_eye.vti.series").write_text(json.dumps(series, indent=1) + "\n")


if __name__ == "__main__":
    main()
