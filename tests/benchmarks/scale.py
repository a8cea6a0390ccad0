"""Benchmark: the sweep at cluster scale, a 201 x 201 phi1/phi2 grid of both hinge sets
(80 802 cells) on a local Dask cluster (distributed.LocalCluster, one single-threaded
process per worker) of 1, 2 and 4 workers.

For each cluster, the client is a process of its own (so its memory is its own) that runs
the sweep on the cluster as `dacm sweep --scheduler ADDRESS --no-plots` does (CLIENT: rows
merged as they arrive, checkpoints, the dataset saved; no CSV or tables). Prints one JSON
object with, per worker count: the client's wall time and cells per second (imports, the
sweep, the dataset), the client's peak RSS, each worker's peak RSS
(psutil, sampled every 0.2 s) and the dataset's size on disk; and the client's peak RSS
of the same command at 51 x 51 on 2 workers, from which the growth per cell is derived.
The cores of this machine (os.sched_getaffinity) and the load average before and after are
printed too: more workers than cores share the cores. About 6 minutes on 2 quiet cores.

Run from the repository root: python -m tests.benchmarks.scale [--n 201] [--workers 1 2 4] [--small-n 51]
"""

import argparse
import json
import os
import sys
import tempfile
import threading
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import psutil  # noqa: E402
from distributed import Client, LocalCluster  # noqa: E402

from sensor.design_space.spec import SweepSpec  # noqa: E402
from tests.benchmarks.sweep import command_usage  # noqa: E402

#: The client: run_sweep on the cluster, rows merged into the dataset as they arrive and
#: checkpointed to OUT, then the dataset saved, as `dacm sweep --scheduler` does, with a
#: cluster timeout of CLUSTER_TIMEOUT_S: on a loaded machine the default 10 s took a cluster
#: that had not finished its first row for a lost one.
CLUSTER_TIMEOUT_S = 300.0
CLIENT = f"""
import sys
from pathlib import Path
from sensor.design_space.dataset import save_dataset
from sensor.design_space.execution import run_sweep
from sensor.design_space.spec import Grid, SweepSpec
address, n, path = sys.argv[1], int(sys.argv[2]), Path(sys.argv[3])
d = SweepSpec()
spec = SweepSpec(phi1=Grid(d.phi1.start, d.phi1.stop, n), phi2=Grid(d.phi2.start, d.phi2.stop, n))
ds, _ = run_sweep(spec, "bench", path, scheduler=address, cluster_timeout_s={CLUSTER_TIMEOUT_S})
save_dataset(ds, path)
"""


class PeakRSS:
    """Peak resident memory (MB) of some processes, sampled every ``period_s`` in a thread."""

    def __init__(self, pids: list[int], period_s: float = 0.2):
        self.procs = {pid: psutil.Process(pid) for pid in pids}
        self.peak = {pid: 0.0 for pid in pids}
        self.period_s = period_s
        self.stop = threading.Event()
        self.thread = threading.Thread(target=self._run, daemon=True)

    def _run(self):
        while not self.stop.wait(self.period_s):
            for pid, p in self.procs.items():
                try:
                    self.peak[pid] = max(self.peak[pid], p.memory_info().rss / 2**20)
                except psutil.Error:
                    pass

    def __enter__(self):
        self.thread.start()
        return self

    def __exit__(self, *exc):
        self.stop.set()
        self.thread.join()


def sweep_on_cluster(n_workers: int, n: int, out: Path) -> dict:
    """One `dacm sweep` of an n x n grid on a fresh local cluster of ``n_workers``."""
    with LocalCluster(n_workers=n_workers, threads_per_worker=1, processes=True,
                      dashboard_address=None, memory_limit=0) as cluster, Client(cluster) as client:
        pids = list(client.run(os.getpid).values())
        with PeakRSS(pids) as workers:
            wall_s, client_mb, _ = command_usage(cluster.scheduler_address, str(n), str(out / "sweep.nc"),
                                                 program=CLIENT)
    cells = len(SweepSpec().hinge_sets) * n * n
    return {"cells": cells, "wall_s": round(wall_s, 1), "cells_per_s": round(cells / wall_s),
            "client_peak_rss_MB": round(client_mb), "worker_peak_rss_MB": sorted(round(v) for v in workers.peak.values()),
            "dataset_MB": round((out / "sweep.nc").stat().st_size / 2**20, 1)}


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=201, help="grid points per axis (default 201)")
    ap.add_argument("--workers", type=int, nargs="+", default=[1, 2, 4])
    ap.add_argument("--small-n", type=int, default=51, help="grid of the second memory point (default 51)")
    args = ap.parse_args()
    result = {"cores": len(os.sched_getaffinity(0)), "load_average_before": os.getloadavg(), "grid": f"{args.n}x{args.n}"}
    with tempfile.TemporaryDirectory() as tmp:
        runs = {}
        for w in args.workers:
            runs[w] = sweep_on_cluster(w, args.n, Path(tmp))
            print(json.dumps({w: runs[w]}), file=sys.stderr, flush=True)  # progress
        small_n = args.small_n
        small = sweep_on_cluster(2, small_n, Path(tmp))
    result["workers"] = runs
    big = runs[2] if 2 in runs else next(iter(runs.values()))
    result["client_peak_rss_MB_at"] = {f"{small_n}x{small_n}": small["client_peak_rss_MB"],
                                       f"{args.n}x{args.n}": big["client_peak_rss_MB"]}
    result["client_kB_per_cell"] = round(
        (big["client_peak_rss_MB"] - small["client_peak_rss_MB"]) * 1024 / (big["cells"] - small["cells"]), 2)
    result["dataset_kB_per_cell"] = round(big["dataset_MB"] * 1024 / big["cells"], 3)
    result["load_average_after"] = os.getloadavg()
    print(json.dumps(result))


if __name__ == "__main__":
    main()
