"""Benchmark of the MRI SNR through the Python API, files to SNR with decoding included:
a 256 x 256 DICOM pair (the real Siemens pair; thesis and nema methods, default ROIs, pair
checks) and a 512 x 512 x 100 volume pair (NPY). Prints one JSON object: medians over
repeats of wall time, ``pair_ms`` (target 3 ms) and ``volume_s`` (target 1 s), and of the
thread's CPU time, ``pair_cpu_ms`` and ``volume_cpu_s`` (steadier on a shared machine: time
spent waiting for a core is not counted).

Run from the checkout: ``python -m tests.benchmarks.snr``.
"""

from __future__ import annotations

import json
import statistics
import tempfile
import time
from pathlib import Path

import numpy as np

from mri.io import load_image
from mri.pair import check_pair
from mri.roi import parse_roi
from mri.snr import DEFAULT_ROIS, measure_arrays

REAL = Path(__file__).resolve().parents[1] / "data" / "mri" / "siemens_aera_pair"
SPECS = {method: (parse_roi(DEFAULT_ROIS[method]),) for method in ("thesis", "nema")}


def files_to_snr(path_a, path_b):
    a, b = load_image(path_a), load_image(path_b)
    check_pair(a, b)
    return measure_arrays(a.pixels, b.pixels, a.pixel_spacing_mm, SPECS)


def median_s(repeats: int, fn, *args) -> tuple[float, float]:
    """Medians of the wall time and of the thread's CPU time of ``fn(*args)``, seconds."""
    wall, cpu = [], []
    for _ in range(repeats):
        start, start_cpu = time.perf_counter(), time.thread_time()
        fn(*args)
        cpu.append(time.thread_time() - start_cpu)
        wall.append(time.perf_counter() - start)
    return statistics.median(wall), statistics.median(cpu)


def volume(seed: int, shape=(100, 512, 512)) -> np.ndarray:
    rng = np.random.default_rng(seed)
    r, c = np.ogrid[: shape[1], : shape[2]]
    disc = ((r - 255.5) ** 2 + (c - 255.5) ** 2 <= 220**2) * 1000.0
    return (disc + rng.normal(0, 10, shape) + 50).clip(0).astype(np.uint16)


def main() -> None:
    pair = (REAL / "tra_250_2meas_1.IMA", REAL / "tra_250_2meas_2.IMA")
    files_to_snr(*pair)  # warm-up: imports and caches
    pair_s, pair_cpu_s = median_s(200, files_to_snr, *pair)
    with tempfile.TemporaryDirectory() as tmp:
        paths = [Path(tmp) / "a.npy", Path(tmp) / "b.npy"]
        for seed, path in enumerate(paths):
            np.save(path, volume(seed))
        files_to_snr(*paths)
        volume_s, volume_cpu_s = median_s(5, files_to_snr, *paths)
    print(json.dumps({
        "pair_ms": round(1e3 * pair_s, 2), "pair_cpu_ms": round(1e3 * pair_cpu_s, 2),
        "pair_target_ms": 3.0,
        "volume_s": round(volume_s, 3), "volume_cpu_s": round(volume_cpu_s, 3), "volume_target_s": 1.0,
        "volume_shape": [100, 512, 512],
    }))


if __name__ == "__main__":
    main()
