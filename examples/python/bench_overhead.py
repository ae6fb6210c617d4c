"""What Python adds to a render: the wall time of `tetkit.render` against
the time the engine reports for the same call (bake or table load, scene,
frame), on NASA's Blunt Fin at 512² with a TF of narrow density peaks.
Prints both per round and the overhead's share; run from the repository
root after building the package (`make python-test` or `pip install ./python`):

    python examples/python/bench_overhead.py [rounds]
"""

import os
import sys
import time

import numpy as np

import tetkit

rounds = int(sys.argv[1]) if len(sys.argv) > 1 else 5
data = "tests/data/plot3d/"
bundle = tetkit.read(data + "bluntfinxyz.bin", scalar="density", q=data + "bluntfinq.bin")
tf = {
    "normalized": True,
    "color": [[0, 0.1, 0.2, 1], [0.5, 1, 0.9, 0.2], [1, 1, 0.1, 0]],
    "opacity": [[0.3, 0], [0.35, 6], [0.4, 0], [0.6, 0], [0.65, 10], [0.7, 0]],
    "unit_distance": 1,
}
print(f"{bundle}; threads: RAYON_NUM_THREADS={os.environ.get('RAYON_NUM_THREADS', 'all')}")
shares = []
for r in range(rounds):
    t = time.perf_counter()
    image, figures = tetkit.render(bundle, tf=tf, azimuth=35, elevation=25, size=(512, 512), stats=True)
    wall = time.perf_counter() - t
    engine = figures["engine_seconds"]
    shares.append((wall - engine) / wall)
    print(f"round {r}: python {wall:.4f} s, engine {engine:.4f} s (frame {figures['frame_seconds']:.4f} s), "
          f"overhead {1e3 * (wall - engine):.2f} ms = {100 * shares[-1]:.2f}%")
print(f"overhead share: median {100 * float(np.median(shares)):.2f}%, max {100 * max(shares):.2f}%")
