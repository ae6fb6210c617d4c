#!/bin/bash
# `tetview render --distributed` on the 20M-tet volume of walker.md (the 160³ grid, 5-split):
# partition time and memory, each rank's peak memory and times under mpirun, compositing,
# against one process drawing the unsplit bundle (distributed.md). Run from the repository root.
set -e
T=${CARGO_TARGET_DIR:-target}/release
cargo build --release -p tetprep
cargo build --release -p tetview --features mpi
B=${BENCH_DIR:-/work/bench}
mkdir -p $B
[ -f $B/g160.raw ] || python3 crates/tetview/results/mkraw.py 160 $B/g160.raw
[ -f $B/g160.tetb ] || $T/tetprep convert $B/g160.raw --format raw --dims 160,160,160 --type f32 --endian little -o $B/g160.tetb
TF=formats/samples/tf_normalized.json
V="--size 512x512 --azimuth 30 --elevation 20 --method exact --no-early-termination"
ROOT=$([ "$(id -u)" = 0 ] && echo --allow-run-as-root)
/usr/bin/time -f "one process: peak %M KB, %e s wall, %U+%S s cpu" \
  $T/tetview render $B/g160.tetb --tf $TF $V -o /tmp/g160_one.png --float /tmp/g160_one.npy --json | grep -E '"(total|raster|view)_seconds"|tets_total'
for n in ${PARTS:-2 3 4}; do
  /usr/bin/time -f "partition into $n: peak %M KB, %e s wall, %U+%S s cpu" \
    $T/tetprep partition $B/g160.tetb --parts $n -o $B/g160_p$n --force -q
  $T/tetprep info $B/g160_p$n | grep -E "piece|tets" | head -8
  # One rayon thread a rank: np = 2 fills the two cores, np 3 and 4 oversubscribe them.
  mpirun --oversubscribe $ROOT -np $n -x RAYON_NUM_THREADS=1 /usr/bin/time -f "rank of $n: peak %M KB, %e s wall, %U+%S s cpu" \
    $T/tetview render $B/g160_p$n --distributed --tf $TF $V -o /tmp/g160_d$n.png --float /tmp/g160_d$n.npy --json \
    | grep -E '"(total|raster)_seconds"|composite|tets_total|"ranks"'
  $T/tetview diff /tmp/g160_one.npy /tmp/g160_d$n.npy | grep -E "RMSE|8-bit"
done
