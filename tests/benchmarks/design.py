"""Benchmark: `dacm design`'s search (DESIGN section 13). Prints one JSON object:

* nominal_s: the 5 N proposed design (optimise, in this process, serial), wall time;
* robust_s: the robust 5 N design from that nominal answer (wall time; the robust mode's
  total is nominal_s + robust_s; the issue's target: within 10 x nominal_s);
* h_gap_to_reference_pct: per range (1, 2, 5, 10, 15 N), 100 (H / H_reference - 1) against
  the stored reference search (tests/design_space/data/reference_search.json; negative: the
  optimiser found a better body);
* seed_spread_pct: at 5 N, 100 (max H / min H - 1) over seeds 0-4;
* sweep_s: the default sweep's solve phase (run_sweep, 41 x 41, both hinge sets, serial)
  measured in the same run, so nominal_s / sweep_s holds on any machine.

Run from the repository root: python -m tests.benchmarks.design
"""

import json
import os
import time
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

from sensor.design_space.execution import run_sweep  # noqa: E402
from sensor.design_space.optimise import DesignProblem, optimise  # noqa: E402
from sensor.design_space.robust import robust  # noqa: E402
from sensor.design_space.spec import SweepSpec  # noqa: E402

REFERENCE = Path(__file__).resolve().parents[1] / "design_space" / "data" / "reference_search.json"
RANGES_N = (1.0, 2.0, 5.0, 10.0, 15.0)


def timed(fn, *args, **kw):
    t0 = time.perf_counter()
    out = fn(*args, **kw)
    return out, time.perf_counter() - t0


def main():
    ref = json.loads(REFERENCE.read_text())
    p5 = DesignProblem(5.0)
    nominal, nominal_s = timed(optimise, p5)
    rob, robust_s = timed(robust, p5, nominal.design)
    gaps = {}
    for r in RANGES_N:
        if ref[f"proposed-{r:g}"]["hysteresis"] is None:   # beyond reach: nothing to compare
            gaps[f"{r:g}"] = None
            continue
        res = nominal if r == 5.0 else optimise(DesignProblem(r))
        gaps[f"{r:g}"] = round(100 * (res.hysteresis / ref[f"proposed-{r:g}"]["hysteresis"] - 1), 3)
    hs = [nominal.hysteresis] + [optimise(DesignProblem(5.0, seed=s)).hysteresis for s in range(1, 5)]
    _, sweep_s = timed(run_sweep, SweepSpec(), "bench", workers=1)
    print(json.dumps({"nominal_s": round(nominal_s, 2), "robust_s": round(robust_s, 2),
                      "robust_over_nominal": round((nominal_s + robust_s) / nominal_s, 2),
                      "robust_constraints_met": rob.met,
                      "h_gap_to_reference_pct": gaps, "seed_spread_pct": round(100 * (max(hs) / min(hs) - 1), 3),
                      "sweep_s": round(sweep_s, 2), "nominal_over_sweep": round(nominal_s / sweep_s, 3),
                      "evaluations_5N": nominal.evaluations, "cores": os.cpu_count(),
                      "load_average_1min": round(os.getloadavg()[0], 1)}))


if __name__ == "__main__":
    main()
