#!/bin/sh
# tetview bench on the issue-6 datasets. Run from the repository root after
# `cargo build --release -p tetprep -p tetview`; bundles and the reference cache go to the current directory.
set -e
D=/work/shared/data
T=formats/samples/tf_normalized.json
P=target/release/tetprep
V=target/release/tetview
R=crates/tetview/results
$P convert $D/bluntfin/bluntfinxyz.bin --q $D/bluntfin/bluntfinq.bin --scalar density -o bluntfin.tetb
$P convert $D/combustor/combxyz.bin --q $D/combustor/combq.bin --scalar density -o combustor.tetb
$P convert $D/points/stars_lum_ci.ply -o stars.tetb
$P convert $D/volumes/ironProt.vtk -o ironprot.tetb
$V bench bluntfin.tetb combustor.tetb --tf $T --size 512x512 --views 2 --repeat 3 --cache cache \
   -o $R/cfd.png --json $R/cfd.json > $R/cfd.md
$V bench stars.tetb --tf $T --size 512x512 --views 1 --repeat 3 --cache cache \
   -o $R/stars.png --json $R/stars.json > $R/stars.md
$V bench ironprot.tetb --tf $T --size 512x512 --views 1 --repeat 3 --cache cache \
   -o $R/ironprot.png --json $R/ironprot.json > $R/ironprot.md
