"""Benchmark: the default sweep (both hinge sets, 41 x 41) and how it scales.

Prints one JSON object:
* wall_s: the whole `dacm sweep` command of this checkout (interpreter start, imports, the
  sweep on every core, dataset, CSV, Pareto tables, every figure), median of 3 runs, and
  its peak resident memory per process (the largest of the command and its workers);
  wall_in_reference: the same in units of the reference computation (reference.py) run
  before each, with the last round's 5 s target in those units; cpu_in_reference_cpu: the
  command's CPU time (it and its workers) over the reference's, steady under load;
* cells_per_s: the solve phase (run_sweep on every core) at 21^2, 41^2 and 81^2 phi1 x phi2
  cells per hinge set: linear scaling keeps it flat;
* peak_rss_MB: peak resident memory of `dacm sweep --workers 1 --no-plots` (one process
  holds the dataset and solves every row) at the same grids: the growth per cell shows the
  dataset is the only thing that grows with the grid.

Run from the repository root: python -m tests.benchmarks.sweep
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
from sensor.design_space.spec import Grid, SweepSpec  # noqa: E402
from tests.benchmarks.reference import in_reference, reference, target  # noqa: E402

ROOT = Path(__file__).resolve().parents[2]
# the console command `dacm` (sensor.cli.run), run by this checkout's interpreter
DACM = "from sensor.cli import run; run()"
SIZES = (21, 41, 81)


def command(*args, env: dict | None = None) -> tuple[float, float]:
    """Wall time (s) and peak RSS (MB, largest process) of one `dacm` command run alone."""
    wall_s, rss_mb, _ = command_usage(*args, env=env)
    return wall_s, rss_mb


def command_usage(*args, env: dict | None = None, program: str = DACM) -> tuple[float, float, float]:
    """Wall time (s), peak RSS (MB, largest process) and CPU time (s, user + system of the
    command and its workers) of one `dacm` command (or other ``python -c`` program) run
    alone, in ``env`` (default: this process's environment)."""
    code = ("import resource, subprocess, sys, time; t = time.perf_counter(); "
            "r = subprocess.run(sys.argv[1:], capture_output=True, text=True); "
            "sys.exit(r.stderr[-2000:]) if r.returncode else None; "
            "u = resource.getrusage(resource.RUSAGE_CHILDREN); "
            "print(time.perf_counter() - t, u.ru_maxrss / 1024, u.ru_utime + u.ru_stime)")
    run = subprocess.run([sys.executable, "-c", code, sys.executable, "-c", program, *args],
                         cwd=ROOT, capture_output=True, text=True, env=env)
    if run.returncode:
        raise RuntimeError(f"dacm {' '.join(args)} failed: {run.stderr.strip()}")
    out = run.stdout.split()
    return float(out[0]), float(out[1]), float(out[2])


def grid(n: int) -> list[str]:
    d = SweepSpec()
    return ["--phi1", f"{d.phi1.start:g}:{d.phi1.stop:g}:{n}", "--phi2", f"{d.phi2.start:g}:{d.phi2.stop:g}:{n}"]


def main():
    d = SweepSpec()
    out = {"cells": len(d.hinge_sets) * d.phi1.n * d.phi2.n, "workers": os.cpu_count()}
    with tempfile.TemporaryDirectory() as tmp:
        runs, refs = [], []
        for _ in range(3):  # alternately with the reference computation
            refs.append(reference())
            runs.append(command_usage("sweep", "--out", tmp, "--quiet", "--force"))
        out["wall_s"] = round(sorted(r[0] for r in runs)[1], 2)
        out["cpu_s"] = round(sorted(r[2] for r in runs)[1], 2)
        out["reference_s"] = round(sorted(r[0] for r in refs)[1], 4)
        out["wall_in_reference"] = sorted(in_reference(r[0], ref[0]) for r, ref in zip(runs, refs))[1]
        out["cpu_in_reference_cpu"] = sorted(in_reference(r[2], ref[1]) for r, ref in zip(runs, refs))[1]
        out["target_wall_in_reference"] = target("sweep_wall")
        out["wall_runs_s"] = [round(r[0], 2) for r in runs]
        out["command_peak_rss_MB_per_process"] = round(max(r[1] for r in runs), 1)
        out["cells_per_s"], out["peak_rss_MB"] = {}, {}
        for n in SIZES:
            spec = SweepSpec(phi1=Grid(d.phi1.start, d.phi1.stop, n), phi2=Grid(d.phi2.start, d.phi2.stop, n))
            t0 = time.perf_counter()
            run_sweep(spec, "bench")
            out["cells_per_s"][f"{n}x{n}"] = round(len(d.hinge_sets) * n * n / (time.perf_counter() - t0))
            _, rss = command("sweep", "--out", tmp, "--quiet", "--force", "--workers", "1", "--no-plots", *grid(n))
            out["peak_rss_MB"][f"{n}x{n}"] = round(rss, 1)
    out["load_average"] = os.getloadavg()
    print(json.dumps(out))


if __name__ == "__main__":
    main()
