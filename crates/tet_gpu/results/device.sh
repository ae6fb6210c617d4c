#!/bin/sh
# One prepared run on a lent GPU machine (the workplace's `device` tool), for
# issue 7's real-GPU figures: tets/s of the 1.85M-tet class of mesh at 1024²
# (stage split, both rasterizers, CPU and GPU orders) and GPU bake times.
#
# Here, first:   make device-bin        (release examples, stripped, in target/device)
# Then:          run(command="sh crates/tet_gpu/results/device.sh",
#                    carry=["target/device"], timeout_s=480)
# Everything lands under $OUT (the tool copies it back); the last lines
# printed are a summary. The device machine has no Rust toolchain and no
# network: the binaries are built here. Whether its image carries a Vulkan
# loader and NVIDIA's Vulkan ICD is not known until tried, so the script
# records what it finds and tries Vulkan, then GL.
set -u
B=target/device
OUT=${OUT:-out/device}
# CELLS/SMALL/SIZE only to try the script here on lavapipe (e.g. CELLS=8 SMALL=6 SIZE=256).
CELLS=${CELLS:-72}
SMALL=${SMALL:-40}
SIZE=${SIZE:-1024}
mkdir -p "$OUT"
{
  date -u
  nvidia-smi --query-gpu=name,driver_version,memory.total,clocks.sm,clocks.max.sm --format=csv 2>&1
  ls -l /usr/share/vulkan/icd.d /etc/vulkan/icd.d /usr/share/glvnd/egl_vendor.d 2>&1
  ldconfig -p 2>/dev/null | grep -E "libvulkan|libEGL|libGLX_nvidia" 2>&1
  ldd "$B/gpu_render" 2>&1
} > "$OUT/machine.txt" 2>&1
ok=""
for backend in vulkan gl; do
  # 72³ cells × 5 = 1,866,240 tets at 1024², 6 frames per mode (the first warms up).
  if WGPU_BACKEND=$backend timeout 200 "$B/gpu_render" "$CELLS" "$SIZE" 6 "$OUT/g$CELLS-$backend" > "$OUT/render-$backend.txt" 2>&1; then
    ok=$backend
    break
  fi
done
if [ -n "$ok" ]; then
  WGPU_BACKEND=$ok timeout 150 "$B/gpu_render" "$SMALL" "$SIZE" 6 > "$OUT/render40-$ok.txt" 2>&1
  [ -n "${NO_BAKE:-}" ] || WGPU_BACKEND=$ok timeout 150 "$B/gpu_bake" > "$OUT/bake-$ok.txt" 2>&1
fi
echo "== machine"; head -3 "$OUT/machine.txt"
for f in "$OUT"/render-*.txt "$OUT"/render40-*.txt "$OUT"/bake-*.txt; do
  [ -f "$f" ] && { echo "== $f"; tail -25 "$f"; }
done
[ -n "$ok" ] || { echo "no backend worked: see machine.txt and render-*.txt"; exit 1; }
