#!/usr/bin/env bash
# Coverage-guided fuzzing of every reader on the STABLE toolchain: libFuzzer
# via libfuzzer-sys, with LLVM's sanitizer-coverage passes requested through
# stable -C flags (what cargo-fuzz adds, minus the nightly-only ASan).
# Overflow checks and debug assertions are on, so arithmetic bugs panic.
#
#   fuzz/run.sh [SECONDS_PER_TARGET] [TARGET...]
#
# Seeds come from tests/data; crashes land in fuzz/artifacts/TARGET/. Pin
# each finding as a regression test in the reader's tests before fixing it.
set -euo pipefail
cd "$(dirname "$0")"
secs="${1:-60}"
shift || true
targets=("$@")
[ ${#targets[@]} -gt 0 ] || targets=(vtk_legacy vtk_xml gmsh plot3d nrrd tetgen su2 exodus openfoam series raw ply las csv bundle convert delaunay lut tf_json view_json render walk shadow manifest)
host=$(rustc -vV | sed -n 's/^host: //p')
export CARGO_TARGET_DIR="${CARGO_TARGET_DIR:-target}"
export RUSTFLAGS="-Cpasses=sancov-module -Cllvm-args=-sanitizer-coverage-level=4 \
 -Cllvm-args=-sanitizer-coverage-inline-8bit-counters -Cllvm-args=-sanitizer-coverage-pc-table \
 -Cllvm-args=-sanitizer-coverage-trace-compares -Cdebug-assertions -Coverflow-checks --cfg fuzzing"
# --target keeps the instrumentation out of build scripts and proc macros.
cargo build --release --target "$host"
bin="$CARGO_TARGET_DIR/$host/release"
data=../tests/data
seed() { # target, files...
    local t=$1; shift
    mkdir -p "corpus/$t"
    for f in "$@"; do
        [ -f "$f" ] && [ "$(stat -c %s "$f")" -lt 300000 ] && cp "$f" "corpus/$t/" || true
    done
}
seed vtk_legacy "$data"/vtk/*.vtk
seed convert "$data"/vtk/*.vtk
seed vtk_xml "$data"/vtu/*.vt? "$data"/vtu/*.pvtu
seed gmsh "$data"/gmsh/*.msh
seed nrrd "$data"/volume/*.nrrd "$data"/volume/*.nhdr
seed bundle ../formats/samples/*.tetb
seed lut ../formats/samples/*.tetl
seed manifest ../formats/samples/manifest_*.json
seed tf_json ../formats/samples/tf_*.json ../crates/tetlut/tests/data/*.json ../crates/tet_preint/tests/data/vtk/tf_*.json
mkdir -p corpus/view_json
printf '{"position":[0,-5,1],"focal_point":[0,0,0],"view_up":[0,0,1],"view_angle":30,"parallel":false,"parallel_scale":1,"size":[64,48]}' > corpus/view_json/view
mkdir -p corpus/plot3d corpus/raw corpus/tetgen corpus/ply corpus/las corpus/csv corpus/delaunay
# Delaunay: mode byte 0 (grid coordinates), a 2×2×2 cube plus its centre.
printf '\x00\x00\x00\x00\x02\x00\x00\x00\x02\x00\x02\x02\x00\x00\x00\x02\x02\x00\x02\x00\x02\x00\x02\x02\x02\x02\x02\x01\x01\x01' > corpus/delaunay/cube
# Render: mode, azimuth, elevation, zoom, scalar seed, spare; then the same cube points.
mkdir -p corpus/render
printf '\x00\x20\xa0\x00\x03\x00\x00\x00\x00\x02\x00\x00\x00\x02\x00\x02\x02\x00\x00\x00\x02\x02\x00\x02\x00\x02\x00\x02\x02\x02\x02\x02\x01\x01\x01' > corpus/render/cube
# Walk: the same head (mode 4: edge-on camera), then the cube with its centre.
mkdir -p corpus/walk
printf '\x04\x01\x01\x00\x03\x08\x00\x00\x00\x02\x00\x00\x00\x02\x00\x02\x02\x00\x00\x00\x02\x02\x00\x02\x00\x02\x00\x02\x02\x02\x02\x02\x01\x01\x01' > corpus/walk/cube_edge_on
# Shadow: mode (lattice, one light), azimuth, elevation, scalar seed, size; the TF (4 narrow peaks
# of extinction 10^2); two lights' 7 bytes (a directional light, a point light beside the box); the cube.
mkdir -p corpus/shadow
printf '\x00\x20\xa0\x03\x04\x03\x80\x10\x80\x00\x30\x40\x20\x80\x00\x00\x04\x90\x70\x60\x80\x00\x00\x00\x00\x00\x00\x02\x00\x00\x00\x02\x00\x02\x02\x00\x00\x00\x02\x02\x00\x02\x00\x02\x00\x02\x02\x02\x02\x02\x01\x01\x01' > corpus/shadow/cube
head -c 200000 "$data"/points/stars_lum_ci.ply > corpus/ply/stars_head
head -c 100000 "$data"/points/autzen_trim.las > corpus/las/autzen_head
printf 'x,y,z,value\n0,0,0,1\n1,0,0,2\n0,1,0,3\n0,0,1,4\n' > corpus/csv/small.csv
# PLOT3D: a control byte (split point), then a grid and Q file.
head -c 20000 "$data"/plot3d/bluntfinxyz.bin > corpus/plot3d/bf_head
# (head closes the pipe early: the writer's SIGPIPE is expected, not an error)
{ printf '\x40'; cat "$data"/plot3d/bluntfinxyz.bin "$data"/plot3d/bluntfinq.bin; } | head -c 250000 > corpus/plot3d/bf || true
{ printf '\x10\x10\x10\x01\x00\x01\x00\x00'; head -c 4104 "$data"/volume/iron16.raw; } > corpus/raw/iron16
# SU2: the brick mesh's head (elements), then its point section's head, a NUL and a CSV solution.
mkdir -p corpus/su2
{ printf 'NDIME= 3\nNELEM= 1\n10 0 1 2 3\nNPOIN= 4\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n\0PointID,x,y,z,p\n0,0,0,0,1\n1,1,0,0,2\n2,0,1,0,3\n3,0,0,1,4\n'; } > corpus/su2/tet
gzip -dc "$data"/su2/mesh_brick_prism_ffd.su2.gz | head -c 60000 > corpus/su2/brick_head || true
# Exodus II: the hand-made three-block, two-step file, step 1.
mkdir -p corpus/exodus
{ printf '\1'; cat "$data"/exodus/small.exo; } > corpus/exodus/small
{ printf '\1'; cat "$data"/exodus/face_nodes.exo; } > corpus/exodus/face_nodes
# OpenFOAM: the four polyMesh files joined by NULs (the binary two-cell case, the cavity's heads).
mkdir -p corpus/openfoam
for c in 64BitFloats; do
    pm="$data"/openfoam/$c/constant/polyMesh
    { cat "$pm"/points; printf '\0'; cat "$pm"/faces; printf '\0'; cat "$pm"/owner; printf '\0'; cat "$pm"/neighbour; } > corpus/openfoam/$c
done
pm="$data"/openfoam/cavity/constant/polyMesh
{ cat "$pm"/points; printf '\0'; cat "$pm"/faces; printf '\0'; cat "$pm"/owner; printf '\0'; cat "$pm"/neighbour; } > corpus/openfoam/cavity
# Time series: the Isabel .pvd (kind byte 0) and .series JSON (kind byte 1).
mkdir -p corpus/series
{ printf '\0'; cat "$data"/series/isabel_eye.pvd; } > corpus/series/pvd
{ printf '\1'; cat "$data"/series/isabel_eye.vti.series; } > corpus/series/json
{ head -c 3000 "$data"/tetgen/twobox.1.node; printf '\0'; head -c 3000 "$data"/tetgen/twobox.1.ele; } > corpus/tetgen/twobox
status=0
for t in "${targets[@]}"; do
    mkdir -p "artifacts/$t"
    echo "== $t ($secs s)"
    if ! "$bin/$t" "corpus/$t" -max_total_time="$secs" -rss_limit_mb=2048 -max_len=300000 \
        -artifact_prefix="artifacts/$t/" -print_final_stats=1 2>"artifacts/$t.log"; then
        echo "!! $t found a crash: see fuzz/artifacts/$t/ and fuzz/artifacts/$t.log"
        status=1
    fi
    grep -E "stat::number_of_executed_units|stat::peak_rss" "artifacts/$t.log" || true
done
exit $status
