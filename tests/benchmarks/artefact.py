"""Benchmark of the MRI artefact model through the Python API. Prints one JSON object:

- ``field_256_s``: :func:`sensor.artefact.field.field_offset_ppm` on a 256^3 grid holding the
  voxelised sample-b sensor (0.25 mm voxels, 64 mm box), FFT grid 256^3 (``pad_factor`` 1;
  target: under 10 s on 2 cores), median wall time of 3, and ``field_256_cpu_s``, the
  process' CPU time over every thread (steadier on a shared machine: time spent waiting for
  a core is not counted; on 2 free cores the wall time is about half of it);
- ``field_256_padded_s``: the same grid with the default padding (FFT grid 384^3);
- ``predict_s``: :func:`sensor.artefact.prediction.predict` of sample-b at the defaults of
  ``dacm artefact`` (voxelisation, field, distance map, gradient-echo image), once;
- the cores used and the load averages before and after.

Run from the checkout: ``python -m tests.benchmarks.artefact``.
"""

from __future__ import annotations

import json
import os
import statistics
import time

import numpy as np

from geometry.params import preset
from sensor.artefact.field import field_offset_ppm, padded_shape
from sensor.artefact.prediction import Protocol, predict
from sensor.artefact.scene import sensor_scene

N = 256


def timed(repeats: int, fn, *args, **kwargs) -> tuple[float, float]:
    """Medians of the wall time and of the process' CPU time (all threads), seconds."""
    wall, cpu = [], []
    for _ in range(repeats):
        start, start_cpu = time.perf_counter(), time.process_time()
        fn(*args, **kwargs)
        cpu.append(time.process_time() - start_cpu)
        wall.append(time.perf_counter() - start)
    return statistics.median(wall), statistics.median(cpu)


def sensor_grid(n: int = N, voxel_mm: float = 0.25) -> np.ndarray:
    """The sample-b sensor's Δchi (ppm) in water on an n^3 grid (its box cut or filled to n)."""
    scene = sensor_scene(preset("sample-b"), "water", voxel_mm, margin_mm=20.0)
    out = np.zeros((n, n, n), np.float32)
    src = scene.delta_chi_ppm
    take = [min(a, n) for a in src.shape]
    start = [(a - t) // 2 for a, t in zip(src.shape, take)]
    dest = [(n - t) // 2 for t in take]
    out[dest[0]:dest[0] + take[0], dest[1]:dest[1] + take[1], dest[2]:dest[2] + take[2]] = \
        src[start[0]:start[0] + take[0], start[1]:start[1] + take[1], start[2]:start[2] + take[2]]
    return out


def main() -> None:
    load_before = os.getloadavg()
    chi = sensor_grid()
    field_offset_ppm(chi[:64, :64, :64], 0.25, "z")  # warm-up: imports and FFT plans
    wall, cpu = timed(3, field_offset_ppm, chi, 0.25, "z", pad_factor=1.0)
    padded_wall, padded_cpu = timed(1, field_offset_ppm, chi, 0.25, "z")
    predict_wall, predict_cpu = timed(1, predict, preset("sample-b"), Protocol())
    print(json.dumps({
        "grid": [N, N, N],
        "field_256_s": round(wall, 3), "field_256_cpu_s": round(cpu, 3), "target_s": 10.0,
        "field_256_padded_fft_grid": list(padded_shape(chi.shape)),
        "field_256_padded_s": round(padded_wall, 3), "field_256_padded_cpu_s": round(padded_cpu, 3),
        "predict_s": round(predict_wall, 3), "predict_cpu_s": round(predict_cpu, 3),
        "cores": os.cpu_count(),
        "load_average_before": [round(v, 2) for v in load_before],
        "load_average_after": [round(v, 2) for v in os.getloadavg()],
    }))


if __name__ == "__main__":
    main()
