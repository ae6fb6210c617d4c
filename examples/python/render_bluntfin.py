"""tetkit from Python: NASA's Blunt Fin (PLOT3D, tests/data/plot3d) read and
converted, drawn with a TF of narrow density peaks, checked against the exact
reference, and written as PNG and .npy. Run from the repository root after
`pip install ./python` (or `make python-test`, which builds it in a venv):

    python examples/python/render_bluntfin.py
"""

import time

import numpy as np

import tetkit

data = "tests/data/plot3d/"
bundle = tetkit.read(data + "bluntfinxyz.bin", scalar="density", q=data + "bluntfinq.bin")
print(bundle)

tf = {
    "normalized": True,
    "color": [[0, 0.1, 0.2, 1], [0.5, 1, 0.9, 0.2], [1, 1, 0.1, 0]],
    "opacity": [[0.3, 0], [0.35, 6], [0.4, 0], [0.6, 0], [0.65, 10], [0.7, 0]],
    "unit_distance": 1,
}
t = time.perf_counter()
image = tetkit.render(bundle, tf=tf, azimuth=35, elevation=25, size=(512, 512))
print(f"render: {time.perf_counter() - t:.3f} s, {image.shape} {image.dtype}")
reference = tetkit.reference(bundle, tf=tf, azimuth=35, elevation=25, size=(512, 512))
print("error against the exact reference:", tetkit.diff(reference, image))
image.save("bluntfin_python.png")
np.save("bluntfin_python.npy", np.asarray(image))
