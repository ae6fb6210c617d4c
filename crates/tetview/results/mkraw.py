#!/usr/bin/env python3
# A smooth test volume for the walker benchmarks (crates/tetview/results/walker.md):
# four Gaussian blobs plus a sine, f32, N^3 samples. Usage: python3 mkraw.py N out.raw
import array, math, sys
n = int(sys.argv[1]); out = sys.argv[2]
a = array.array('f')
blobs = [(0.3,0.4,0.5,0.12),(0.7,0.6,0.3,0.1),(0.5,0.7,0.7,0.15),(0.25,0.25,0.2,0.08)]
for k in range(n):
    z = k/(n-1)
    for j in range(n):
        y = j/(n-1)
        row = []
        for i in range(n):
            x = i/(n-1)
            v = 0.15*math.sin(7*x+3*y)*math.cos(5*z)
            for (bx,by,bz,r) in blobs:
                d2 = (x-bx)**2+(y-by)**2+(z-bz)**2
                v += math.exp(-d2/(2*r*r))
            row.append(v)
        a.extend(row)
open(out,'wb').write(a.tobytes())
