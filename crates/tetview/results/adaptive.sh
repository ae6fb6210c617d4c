#!/bin/bash
# Adaptive sampling against the full walk (walker.md, "Adaptive image-space sampling"). Needs the
# bundles and certified tables of walker.md in /work/bench and `cargo build --release -p tet_render --example frame_profile`.
# Adaptive sampling in turns: frame_profile, 512², 2 threads, camera moving 2° a frame.
F=/root/.cache/tetkit-target/release/examples/frame_profile
cd /work/bench
for round in 1 2; do
for b in bf comb ip grid60 g160; do
  for a in none 0.004 0.008 0.016; do
    if [ $a = none ]; then unset TET_ADAPTIVE; else export TET_ADAPTIVE=$a; fi
    TET_ORBIT=2 RAYON_NUM_THREADS=2 $F $b.tetb ${b}_t3.tetl 3 2>&1 | grep "frame [12]" | sed -E "s/^frame ([12]) \(walk\): ([0-9.]+) s.* ([0-9]+) crossings, ([0-9]+) rays walked[^,]*, ([0-9]+) interpolated.*cpu ([0-9.]+) s.*/$round $b $a f\1 wall \2 cpu \6 crossings \3 walked \4 interp \5/"
  done
done
done
