"""Benchmark of the MRI SNR through the Python API, files to SNR with decoding included:
a 256 x 256 DICOM pair (the real Siemens pair; thesis and nema methods, default ROIs, pair
checks) and a 512 x 512 x 100 volume pair (NPY). Prints one JSON object: medians over
repeats of wall time, ``pair_ms`` (target 3 ms) and ``volume_s`` (target 1 s), and of the
thread's CPU time, ``pair_cpu_ms`` and ``volume_cpu_s`` (steadier on a shared machine: time
spent waiting for a core is not counted).

The peer, hazen, is measured in the same run on the same DICOM pair, alternately with dacm
in blocks of BLOCK pairs (tests/benchmarks/hazen_peer.py, a child process run by the
interpreter of hazen's own venv, HAZEN_PYTHON, default .venv-hazen/bin/python: hazen pins
numpy < 2.4; ``make bench`` makes it). ``hazen`` gives its version, its median wall times
(``pair_ms``: files to the subtraction SNR of the pair, the work dacm's pair does;
``task_ms``: its whole SNR task, which also smooths each image) and CPU times (``_cpu_ms``),
dacm's over the same blocks (``dacm_ms``), and the ratios. Without hazen there is no ratio. The pair and volume times are also given in units of the
reference computation (reference.py) measured in the same run, beside the last round's
targets (3 ms, 1 s) in those units.

Run from the checkout: ``python -m tests.benchmarks.snr`` (about a minute).
"""

from __future__ import annotations

import json
import os
import statistics
import subprocess
import tempfile
import time
from pathlib import Path

import numpy as np

from mri.io import load_image
from mri.pair import check_pair
from mri.roi import parse_roi
from mri.snr import DEFAULT_ROIS, measure_arrays
from tests.benchmarks.reference import in_reference, reference_s, target

ROOT = Path(__file__).resolve().parents[2]
REAL = ROOT / "tests" / "data" / "mri" / "siemens_aera_pair"
HAZEN_PYTHON = Path(os.environ.get("HAZEN_PYTHON", ROOT / ".venv-hazen" / "bin" / "python"))
BLOCK, BLOCKS = 20, 6
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


def against_hazen(pair) -> dict | str:
    """dacm and hazen on the same pair, alternately in blocks of BLOCK (medians, ms)."""
    if not HAZEN_PYTHON.exists():
        return f"hazen not installed ({HAZEN_PYTHON} missing; make bench makes it): no ratio"
    # in a temporary folder: hazen writes its log file into the working directory
    with tempfile.TemporaryDirectory() as cwd, subprocess.Popen(
            [str(HAZEN_PYTHON), str(Path(__file__).with_name("hazen_peer.py")), *(str(p.resolve()) for p in pair)],
            stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True, cwd=cwd) as peer:
        version = json.loads(peer.stdout.readline())["version"]
        times = {k: [] for k in ("dacm", "dacm_cpu", "pair", "pair_cpu", "task", "task_cpu")}
        for _ in range(BLOCKS):
            for _ in range(BLOCK):
                start, start_cpu = time.perf_counter(), time.thread_time()
                files_to_snr(*pair)
                times["dacm_cpu"].append(time.thread_time() - start_cpu)
                times["dacm"].append(time.perf_counter() - start)
            peer.stdin.write(f"{BLOCK}\n")
            peer.stdin.flush()
            for k, v in json.loads(peer.stdout.readline()).items():
                times[k.removesuffix("_s")] += v
        peer.stdin.close()
    ms = {k: 1e3 * statistics.median(v) for k, v in times.items()}
    return {"name": f"hazen {version}", **{f"{k}_ms": round(v, 2) for k, v in ms.items()},
            "speedup_pair": round(ms["pair"] / ms["dacm"], 1), "speedup_pair_cpu": round(ms["pair_cpu"] / ms["dacm_cpu"], 1),
            "speedup_task": round(ms["task"] / ms["dacm"], 1), "speedup_task_cpu": round(ms["task_cpu"] / ms["dacm_cpu"], 1)}


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
    ref = reference_s()
    print(json.dumps({
        "reference_s": round(ref, 4), "pair_in_reference": in_reference(pair_s, ref),
        "target_pair_in_reference": target("snr_pair"), "volume_in_reference": in_reference(volume_s, ref),
        "target_volume_in_reference": target("snr_volume"),
        "pair_ms": round(1e3 * pair_s, 2), "pair_cpu_ms": round(1e3 * pair_cpu_s, 2),
        "pair_target_ms": 3.0,
        "volume_s": round(volume_s, 3), "volume_cpu_s": round(volume_cpu_s, 3), "volume_target_s": 1.0,
        "volume_shape": [100, 512, 512], "hazen": against_hazen(pair), "load_average": os.getloadavg(),
    }))


if __name__ == "__main__":
    main()
