"""Benchmark of ``dacm snr`` in-process: load to result for a 256 x 256 pair and a 512 x 512 x 200
volume pair (both methods, default ROIs). Prints one JSON object; targets 0.05 s and 2 s."""

from __future__ import annotations

import json
import tempfile
import time
from pathlib import Path

import numpy as np

from mri.io import load_image
from mri.roi import parse_roi
from mri.snr import DEFAULT_ROIS, measure_pair

REAL = Path(__file__).resolve().parents[3] / "shared" / "data" / "mri" / "siemens_aera_pair"
SPECS = {method: (parse_roi(text),) for method, text in DEFAULT_ROIS.items()}


def load_and_measure(path_a, path_b):
    a, b = load_image(path_a), load_image(path_b)
    return measure_pair(a.pixels, b.pixels, a.pixel_spacing_mm, SPECS)


def best_of(repeats, fn, *args) -> tuple[float, float]:
    """Best wall-clock and CPU (this process) times in seconds; CPU time is the steadier one on
    a shared machine."""
    walls, cpus = [], []
    for _ in range(repeats):
        wall, cpu = time.perf_counter(), time.process_time()
        fn(*args)
        walls.append(time.perf_counter() - wall)
        cpus.append(time.process_time() - cpu)
    return min(walls), min(cpus)


def volume(seed: int, shape=(200, 512, 512)) -> np.ndarray:
    rng = np.random.default_rng(seed)
    r, c = np.ogrid[: shape[1], : shape[2]]
    disc = ((r - 255.5) ** 2 + (c - 255.5) ** 2 <= 220**2) * 1000.0
    return (disc + rng.normal(0, 10, shape) + 50).clip(0).astype(np.uint16)


def main() -> None:
    pair = (REAL / "tra_250_2meas_1.IMA", REAL / "tra_250_2meas_2.IMA")
    load_and_measure(*pair)  # warm-up: imports and caches
    t_pair = best_of(5, load_and_measure, *pair)
    with tempfile.TemporaryDirectory() as tmp:
        paths = [Path(tmp) / "a.npy", Path(tmp) / "b.npy"]
        for seed, path in enumerate(paths):
            np.save(path, volume(seed))
        t_volume = best_of(3, load_and_measure, *paths)
    print(json.dumps({
        "pair_256x256_dicom_s": round(t_pair[0], 4),
        "pair_256x256_dicom_cpu_s": round(t_pair[1], 4),
        "pair_256x256_target_s": 0.05,
        "volume_512x512x200_npy_s": round(t_volume[0], 3),
        "volume_512x512x200_npy_cpu_s": round(t_volume[1], 3),
        "volume_512x512x200_target_s": 2.0,
    }))


if __name__ == "__main__":
    main()
