#!/bin/sh
# Lighting and shadows: the rows of lighting.md and the pictures beside it.
# Run from the repository root; writes into crates/tet_engine/results/ and /tmp.
set -e
R=crates/tet_engine/results
T=${CARGO_TARGET_DIR:-target}/release
cargo build --release -p tet_engine --example lighting_bench
cargo build --release -p tetview -p tetprep
$T/tetprep convert tests/data/plot3d/bluntfinxyz.bin --q tests/data/plot3d/bluntfinq.bin --scalar density --gradients -o /tmp/bf.tetb
$T/tetprep convert tests/data/points/autzen_trim.las --gradients -o /tmp/autzen.tetb
# Rows (frames at 512², errors at 96², costs only at 8²): Blunt Fin with the
# sample TF and with a denser one whose shadows show, the Delaunay mesh of
# the Autzen lidar points with its automatic TF, and two 1M-tet meshes of
# /work/bench (ironProt 68³ and a 60³ grid, 6-split) when present.
rm -f $R/lighting_rows.md
$T/examples/lighting_bench /tmp/bf.tetb formats/samples/tf_normalized.json 512 96 $R/lighting_rows.md
$T/examples/lighting_bench /tmp/bf.tetb $R/bf_shadow_tf.json 512 96 $R/lighting_rows.md
$T/examples/lighting_bench /tmp/autzen.tetb $R/autzen_tf.json 512 96 $R/lighting_rows.md
# The held-out TFs (narrow peaks, a sharp 8-node TF, steps, plateaus) on Blunt Fin, errors at 64².
for f in peaks12 sharp8 steps plateaus; do
  $T/examples/lighting_bench /tmp/bf.tetb crates/tet_preint/tests/data/heldout/tf_$f.json 512 64 $R/lighting_rows.md
done
# The narrow peaks from a point light outside the mesh (its refined fan).
TET_LIGHT=point $T/examples/lighting_bench /tmp/bf.tetb crates/tet_preint/tests/data/heldout/tf_peaks12.json 512 64 $R/lighting_rows.md
for b in ip grid60; do
  [ -f /work/bench/$b.tetb ] && $T/examples/lighting_bench /work/bench/$b.tetb formats/samples/tf_normalized.json 512 8 $R/lighting_rows.md
done
# Point lights inside the mesh and beside its box (a cube of maps).
for place in inside beside; do
  TET_LIGHT=$place $T/examples/lighting_bench /tmp/bf.tetb $R/bf_shadow_tf.json 256 64 $R/lighting_rows.md
done
TET_LIGHT=inside $T/examples/lighting_bench /tmp/autzen.tetb $R/autzen_tf.json 256 64 $R/lighting_rows.md
# Pictures: the same light without and with shadows.
for shadows in "" --shadows; do
  name=$([ -n "$shadows" ] && echo shadows || echo lit)
  $T/tetview render /tmp/bf.tetb --tf $R/bf_shadow_tf.json --light-dir 0.6,-0.5,-0.62 \
    --azimuth 34 --elevation 20 --size 512x512 $shadows -o $R/bf_$name.png
  $T/tetview render /tmp/autzen.tetb --tf $R/autzen_tf.json --light-dir 0.6,-0.5,-0.62 \
    --azimuth 34 --elevation 20 --size 512x512 $shadows -o $R/autzen_$name.png
done
# The held-out TF of a dozen narrow peaks with shadows (the map refined nearly everywhere).
$T/tetview render /tmp/bf.tetb --tf crates/tet_preint/tests/data/heldout/tf_peaks12.json --light-dir 0.6,-0.5,-0.62 \
  --azimuth 34 --elevation 20 --size 512x512 --shadows -o $R/bf_peaks12_shadows.png
# A point light outside the mesh (its perspective deep shadow map), without and with shadows.
for n in point point_shadows; do
  $T/tetview render /tmp/bf.tetb --tf $R/bf_shadow_tf.json --view $R/bf_${n}_view.json -o $R/bf_$n.png
done
# The same light's shadows of the dozen narrow peaks (its fan refined to the third grid).
$T/tetview render /tmp/bf.tetb --tf crates/tet_preint/tests/data/heldout/tf_peaks12.json \
  --view $R/bf_point_shadows_view.json -o $R/bf_peaks12_point_shadows.png
# A point light inside the mesh (its cube of maps), without and with shadows.
for n in inside inside_shadows; do
  $T/tetview render /tmp/bf.tetb --tf $R/bf_shadow_tf.json --view $R/bf_${n}_view.json -o $R/bf_$n.png
done
