"""Benchmark: `dacm design --range 5` (the proposed body and the basis body of the same
range), repeated; prints one JSON object with the wall times (median), the evaluations and
the answer. Target: under 60 s on a 2-core machine."""

import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

REPEATS = int(os.environ.get("DACM_BENCH_REPEATS", "3"))


def main():
    dacm = Path(sys.executable).with_name("dacm")
    walls, last = [], None
    for _ in range(REPEATS):
        with tempfile.TemporaryDirectory() as tmp:
            t0 = time.perf_counter()
            run = subprocess.run([str(dacm), "design", "--range", "5", "--out", tmp, "--json"],
                                 check=True, capture_output=True, text=True)
            walls.append(time.perf_counter() - t0)
            last = json.loads(run.stdout)
    print(json.dumps({"command": "dacm design --range 5", "repeats": REPEATS,
                      "wall_s": [round(w, 1) for w in walls], "median_wall_s": round(statistics.median(walls), 1),
                      "target_s": 60, "cores": os.cpu_count(), "evaluations": last["evaluations"],
                      "range_N": round(last["range_N"], 4), "hysteresis_fraction": round(last["hysteresis_fraction"], 5),
                      "basis_hysteresis_fraction": round(last["basis"]["hysteresis_fraction"], 5),
                      "load_average_1min": round(os.getloadavg()[0], 1)}))


if __name__ == "__main__":
    main()
