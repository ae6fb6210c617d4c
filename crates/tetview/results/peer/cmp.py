#!/usr/bin/env python3
# Image errors against tetkit's exact reference: all pixels, and the
# interior (coverage eroded by 3 px: away from the mesh's silhouette), and
# against the reference moved half a pixel (the 4-pixel mean) for renderers
# that sample at pixel corners (VTK's ray caster). Usage: cmp.py REF.npy IMG.npy [IMG.npy ...]
import numpy as np, sys
ref = np.load(sys.argv[1]).astype(np.float64)
H, W, _ = ref.shape
cov = ref[..., 3] > 0
er = cov.copy()
for dy in range(-3, 4):
    for dx in range(-3, 4):
        er &= np.roll(np.roll(cov, dy, 0), dx, 1)
def stats(a, b, m):
    d = np.abs(a - b)[m]
    return np.sqrt((d ** 2).mean()), d.max()
def shifted(r, sy, sx):
    return 0.25 * (r + np.roll(r, -sy, 0) + np.roll(r, -sx, 1) + np.roll(np.roll(r, -sy, 0), -sx, 1))
print(f"interior pixels: {er.sum()} of {cov.sum()} covered")
for f in sys.argv[2:]:
    img = np.load(f).astype(np.float64)
    full = stats(img, ref, np.ones((H, W), bool))
    inner = stats(img, ref, er)
    best = min(((stats(img, shifted(ref, sy, sx), er), (sy, sx)) for sy in (-1, 1) for sx in (-1, 1)), key=lambda t: t[0][0])
    q = np.abs(img * 255 - np.round(img * 255)).max()
    print(f"{f}: all RMSE {full[0]:.2e} max {full[1]:.2e} | interior RMSE {inner[0]:.2e} max {inner[1]:.2e} | "
          f"interior vs ref moved ½ px {best[1]}: RMSE {best[0][0]:.2e} max {best[0][1]:.2e} | on a 1/255 grid: {q < 1e-3}")
