#!/bin/sh
# tetkit against VTK 9.7.2's unstructured-grid volume mappers (the scripts in $PEER,
# /work/shared/peer by default) on the issue-6 bundles: the same camera, TF and size.
# A measuring tool, not part of `make test`. Run from the repository root after
# `cargo build --release -p tetprep -p tetlut -p tetview -p tet_render --example frame_profile`
# and the bundles and tables of crates/tetview/results/bench.sh (B.tetb, and
# `tetlut bake --bundle B.tetb --tf $T --method table3d -o B_128.tetl`) in $W.
# VTK: python3 -m venv $VENV && $VENV/bin/pip install vtk numpy scipy
set -e
W=${W:-/tmp/b}; O=${O:-/tmp/peer}; VENV=${VENV:-/tmp/venv-vtk}
PEER=${PEER:-/work/shared/peer}
T=formats/samples/tf_normalized.json
R=crates/tetview/results/peer
export VTK_DEFAULT_OPENGL_WINDOW=vtkEGLRenderWindow
mkdir -p $O
for d in bluntfin combustor stars ironprot; do
  target/release/tetprep export $W/$d.tetb -o $O/$d.vtu
  # VTK's projected tetrahedra and its exact (linear) ray integrator: first
  # frame, then 3 timed frames each after 2° of azimuth (a re-sort every frame).
  $VENV/bin/python $PEER/vtk_render.py --input $O/$d.vtu --tf $T --mappers pt,rc_linear \
    --size 512 512 --azimuth 30 --elevation 20 --frames 3 --outdir $O --threads 2
  # The camera VTK used, as a tetview view.
  python3 $R/mkview.py $O/${d}_pt.json $O/${d}_view.json
  target/release/tetview reference $W/$d.tetb --tf $T --view $O/${d}_view.json -o $O/${d}_ref.png --float $O/${d}_ref.npy
  target/release/tetview render $W/$d.tetb --lut $W/${d}_128.tetl --view $O/${d}_view.json -o $O/${d}_ours.png --float $O/${d}_ours.npy
  # tetkit's frames on that camera: camera moving 2° a frame, and the same view.
  TET_VIEW=$O/${d}_view.json TET_ORBIT=2 target/release/examples/frame_profile $W/$d.tetb $W/${d}_128.tetl 4
  TET_VIEW=$O/${d}_view.json target/release/examples/frame_profile $W/$d.tetb $W/${d}_128.tetl 4
  # The same algorithm as VTK's PT: tetkit's pt-linear.
  target/release/tetlut bake --bundle $W/$d.tetb --tf $T --method pt-linear -o $O/${d}_ptl.tetl
  TET_VIEW=$O/${d}_view.json TET_ORBIT=2 target/release/examples/frame_profile $W/$d.tetb $O/${d}_ptl.tetl 4
  target/release/tetview render $W/$d.tetb --lut $O/${d}_ptl.tetl --view $O/${d}_view.json -o $O/${d}_ptl.png --float $O/${d}_ptl.npy
  $VENV/bin/python $R/cmp.py $O/${d}_ref.npy $O/${d}_ours.npy $O/${d}_ptl.npy $O/${d}_pt.npy $O/${d}_rc_linear.npy
done
