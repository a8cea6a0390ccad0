"""Benchmark: the default sweep (both hinge sets, 41 x 41), serial and parallel.

Prints one JSON object: configurations per second serial and parallel (the solve phase),
and the wall time of the whole `dacm sweep` command (start to last figure written).
"""

import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

from sensor.design_space.execution import run_sweep  # noqa: E402
from sensor.design_space.spec import SweepSpec


def main():
    spec = SweepSpec()
    n = len(spec.hinge_sets) * spec.phi1.n * spec.phi2.n
    out = {"cells": n}
    for label, workers in (("serial", 1), ("parallel", os.cpu_count() or 2)):
        t0 = time.perf_counter()
        run_sweep(spec, "bench", workers=workers)
        dt = time.perf_counter() - t0
        out[f"{label}_configs_per_s"] = round(n / dt, 1)
        out[f"{label}_s"] = round(dt, 2)
    out["workers_parallel"] = os.cpu_count()
    with tempfile.TemporaryDirectory() as tmp:
        dacm = Path(sys.executable).with_name("dacm")
        t0 = time.perf_counter()
        subprocess.run([str(dacm), "sweep", "--out", tmp, "--quiet"], check=True, capture_output=True)
        out["command_wall_s"] = round(time.perf_counter() - t0, 2)
    out["thesis_estimate_s"] = round(n * 0.5, 1)
    print(json.dumps(out))


if __name__ == "__main__":
    main()
