"""Benchmark: one nonlinear solve of sample B to 1 mm output, and batched solves.

Prints one JSON object: median_ms (one solve, default options), batch_solves_per_s (a
phi1/phi2 batch of 05-03 designs solved together), speedup_vs_thesis (against the thesis'
0.5 s per configuration in MATLAB), and the check that the solve is converged: the largest
relative change of A, k_out and SE when the increment is halved.
"""

import json
import os
import time

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np  # noqa: E402

from geometry.params import make_design, preset  # noqa: E402
from geometry.topology import build_beam_model  # noqa: E402
from sensor.mechanics.solver import SolverOptions, solve, solve_batch  # noqa: E402

THESIS_S = 0.5


def main():
    model = build_beam_model(preset("sample-b"))
    solve(model)  # warm up
    times = []
    for _ in range(60):
        t0 = time.perf_counter()
        r = solve(model)
        times.append(time.perf_counter() - t0)
    median_s = float(np.median(times))
    halved = solve(model, options=SolverOptions(increments=2 * SolverOptions().increments))
    change = max(abs(getattr(halved, q) / getattr(r, q) - 1)
                 for q in ("amplification", "k_out_N_per_mm", "strain_energy_mJ"))
    designs = [make_design(p1, p2) for p1 in np.linspace(10, 28, 10) for p2 in np.linspace(8, 40, 10)]
    models = [build_beam_model(d) for d in designs]
    t0 = time.perf_counter()
    results, errors = solve_batch(models)
    batch_s = time.perf_counter() - t0
    print(json.dumps({
        "median_ms": round(median_s * 1e3, 3),
        "batch_solves_per_s": round(len(models) / batch_s, 1),
        "batch_size": len(models),
        "batch_failed": sum(e is not None for e in errors),
        "speedup_vs_thesis": round(THESIS_S / median_s, 1),
        "max_change_when_increment_halved": change,
        "increments": r.increments,
    }))


if __name__ == "__main__":
    main()
