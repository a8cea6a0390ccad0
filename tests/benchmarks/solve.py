"""Benchmark: one nonlinear solve of sample B to 1 mm output, and batched solves.

Prints one JSON object: median_ms (one solve, default options, after a warm-up), its ratio to
OpenSeesPy on the same problem (7.05 ms, issue 17: co-rotational force-based beams with
shear, 4 elements per member) and to the thesis' 0.5 s per configuration in MATLAB;
batch_ms_per_design (solve_batch over rows of the default sweep: both hinge sets, phi1 rows
0, 10, 20, 30, 40, the feasible designs of each row solved together, failing ones included;
total time / designs, median of 3 repeats); batch_solves_per_s (a 10 x 10 phi1/phi2 batch of
05-03 designs); and the check that the solve is converged: the largest relative change of A,
k_out and SE when the increment is halved.

Run from the repository root: python -m tests.benchmarks.solve
"""

import json
import os
import time

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np

from geometry.checks import check_design
from geometry.params import make_design, preset
from geometry.topology import build_beam_model
from sensor.design_space.spec import SweepSpec
from sensor.mechanics.solver import SolverOptions, solve, solve_batch

THESIS_S = 0.5
OPENSEES_MS = 7.05
ROWS = (0, 10, 20, 30, 40)


def sweep_rows() -> list[list]:
    """The beam models of the feasible proposed designs of some default-sweep rows."""
    spec = SweepSpec()
    rows = []
    for h in spec.hinge_sets:
        for i in ROWS:
            designs = [spec.design(h, spec.phi1.values[i], p) for p in spec.phi2.values]
            rows.append([build_beam_model(d) for d in designs if check_design(d).first_failure is None])
    return rows


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
    rows = sweep_rows()
    n_row = sum(len(m) for m in rows)
    per_design = []
    for _ in range(3):
        t0 = time.perf_counter()
        for models in rows:
            solve_batch(models)
        per_design.append((time.perf_counter() - t0) / n_row)
    designs = [make_design(p1, p2) for p1 in np.linspace(10, 28, 10) for p2 in np.linspace(8, 40, 10)]
    models = [build_beam_model(d) for d in designs]
    t0 = time.perf_counter()
    _, errors = solve_batch(models)
    batch_s = time.perf_counter() - t0
    print(json.dumps({
        "median_ms": round(median_s * 1e3, 3),
        "speedup_vs_opensees": round(OPENSEES_MS / (median_s * 1e3), 1),
        "batch_ms_per_design": round(float(np.median(per_design)) * 1e3, 3),
        "batch_designs": n_row,
        "batch_speedup_vs_opensees": round(OPENSEES_MS / (float(np.median(per_design)) * 1e3), 1),
        "batch_solves_per_s": round(len(models) / batch_s, 1),
        "batch_size": len(models),
        "batch_failed": sum(e is not None for e in errors),
        "speedup_vs_thesis": round(THESIS_S / median_s, 1),
        "max_change_when_increment_halved": change,
        "increments": r.increments,
    }))


if __name__ == "__main__":
    main()
