"""Benchmark: `dacm verify`'s continuum study (DESIGN section 14). Prints one JSON object:

* verify_s: sample B (the ``sample-b`` preset, cut with its 0.8 mm kerf), linear, default
  mesh level (three meshes, 3, 4.24 and 6 elements across each hinge, Richardson),
  ``verify_design`` in this process, wall time (a coarse study runs first, untimed, for the
  imports, the CAD kernel and the compiled kernels of the FE and the beam model);
* mesh_s: of that, the time in ``mesh_profile`` (the cut profile's loops, then gmsh, which
  asks for the size field at every point it places);
* size_field_us: one call of the size field (``_size_function``) at a point of the body's
  box, microseconds.

Run from the repository root: python -m tests.benchmarks.verify
"""

import json
import os
import time

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np  # noqa: E402

from geometry.params import preset  # noqa: E402
from sensor.mechanics import continuum  # noqa: E402


def main():
    design = preset("sample-b")
    continuum.verify_design(design, mesh="coarse")     # imports, CAD and the JIT, not timed
    meshing = [0.0]
    mesh_profile = continuum.mesh_profile

    def timed_mesh(*args, **kw):
        t0 = time.perf_counter()
        out = mesh_profile(*args, **kw)
        meshing[0] += time.perf_counter() - t0
        return out

    size = continuum._size_function(design, 6.0, design.kerf_mm)
    points = np.random.default_rng(0).uniform((-12.5, 0.0), (12.5, 30.0), (20000, 2)).tolist()
    t0 = time.perf_counter()
    for x, y in points:
        size(x, y)
    per_call = (time.perf_counter() - t0) / len(points)
    continuum.mesh_profile = timed_mesh
    try:
        t0 = time.perf_counter()
        continuum.verify_design(design)
        verify_s = time.perf_counter() - t0
    finally:
        continuum.mesh_profile = mesh_profile
    print(json.dumps({"verify_s": round(verify_s, 2), "mesh_s": round(meshing[0], 2),
                      "size_field_us": round(1e6 * per_call, 2),
                      "cores": os.cpu_count(), "load_average_1min": round(os.getloadavg()[0], 1)}))


if __name__ == "__main__":
    main()
