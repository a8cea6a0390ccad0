"""Benchmark: `dacm verify`'s continuum study (DESIGN section 14). Prints one JSON object:

* verify_s: sample B as cut, linear, default mesh (three meshes, 4.24 to 12 elements across
  each hinge, Richardson), ``verify_design`` in this process, wall time (the first solve,
  with the JIT compiled, is run before);
* mesh_s: of that, the time spent meshing (``mesh_profile``: gmsh, asking for the size field
  at every point it places);
* size_field_us: one call of the size field (``_size_function``, what gmsh asks at every
  point it places) at a point of the body's box, microseconds.

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
    continuum.verify(design, mesh="coarse")            # imports, CAD and the JIT, not timed
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
