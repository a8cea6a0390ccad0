"""The fixed reference computation the speed targets are ratios to, measured in the same run
as what it judges, so a target holds on any machine, loaded or not.

It is pure numpy in a Python loop, the kind of work a solve does: SYSTEMS dense 24 x 24
systems solved one at a time (np.linalg.solve, one BLAS thread) after a matrix product and
a norm each, on a fixed seed. ``reference`` gives its median wall and CPU (thread) time.

The targets of the last round (absolute times met on a quiet 2-core machine, issue 17) are
stated in reference units: target time / REFERENCE_QUIET_S, where REFERENCE_QUIET_S is the
reference's time on that machine. It is inferred from the default `dacm sweep`, whose CPU
time on that machine the README gives (1.1 s interpreter and imports, 3.6 s sweep, 3.1 s
data and figures: 7.8 s): CPU times hardly depend on the load, and the command's CPU time
over the reference's, measured alternately three times on the same code (load average
21), was 345-354, so REFERENCE_QUIET_S = 7.8 s / 350 = 0.0223 s (single-threaded, so its
wall time on a quiet machine). A benchmark prints its time divided by the reference
measured beside it, next to the target in the same units: wall over wall is the target's
measure on a quiet machine; on a loaded one only CPU over CPU means anything.
"""

import os
import statistics
import time

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np

SYSTEMS = 2000
SIZE = 24
#: the reference's time on the machine where the last round's targets were met (see above)
REFERENCE_QUIET_S = 7.8 / 350
#: the last round's targets (seconds), in reference units by REFERENCE_QUIET_S
TARGETS_S = {"sweep_wall": 5.0, "solve_median": 2e-3, "batch_per_design": 0.5e-3, "datasheet_median": 0.5,
             "snr_pair": 3e-3, "snr_volume": 1.0}


def _loop(a: np.ndarray, b: np.ndarray) -> float:
    total = 0.0
    for k in range(SYSTEMS):
        m = a[k % len(a)] @ a[(k + 1) % len(a)].T + SIZE * np.eye(SIZE)
        total += float(np.linalg.norm(np.linalg.solve(m, b[k % len(b)])))
    return total


def reference(repeats: int = 7) -> tuple[float, float]:
    """Median wall and CPU time (s) of the reference computation."""
    rng = np.random.default_rng(0)
    a, b = rng.standard_normal((16, SIZE, SIZE)), rng.standard_normal((16, SIZE))
    _loop(a, b)
    wall, cpu = [], []
    for _ in range(repeats):
        t0, c0 = time.perf_counter(), time.thread_time()
        _loop(a, b)
        cpu.append(time.thread_time() - c0)
        wall.append(time.perf_counter() - t0)
    return statistics.median(wall), statistics.median(cpu)


def reference_s(repeats: int = 7) -> float:
    """Median wall time (s) of the reference computation."""
    return reference(repeats)[0]


def in_reference(seconds: float, reference: float) -> float:
    """A time in reference units (the reference measured in the same run)."""
    return round(seconds / reference, 4)


def target(key: str) -> float:
    """The last round's target for ``key`` in reference units."""
    return round(TARGETS_S[key] / REFERENCE_QUIET_S, 4)
