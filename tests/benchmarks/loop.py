"""Benchmark: cost of one observer + controller step, and the chapter V study.

step_us: wall time of one call of the controller callable (observer update, eqs 19-24, and the
control law) averaged over 20 000 synthetic samples, median of 5 repeats, for every controller
(PI, impedance, SMC with the observer's pressures in its law, the thesis' and our line-model
controller with the line-model update and the cascaded law); the largest is reported (target
<= 5 us, issue 17).  chapter5_study_s: the whole 4 lengths x 4 references x 3 controllers grid
of :func:`sensor.pneumatic.studies.controller_study` (5 controller rows, 30 s each, 50 s at 0.5 Hz, 20-segment
distributed lines), the tuning search included.
One core.  Prints one JSON object.
"""
import json
import math
import os
import statistics
import time

from sensor.pneumatic.controllers import CONTROLLERS
from sensor.pneumatic.observer import ObserverModel
from sensor.pneumatic.experiment import Setup, build_plant, make_controller
from sensor.pneumatic.studies import CH5_CONTROLLERS, controller_study


def step_cost(controller: str, n: int = 20000) -> float:
    setup = Setup(controller=controller, observer="force", valve="enfield-lh05")
    model = ObserverModel.from_plant(build_plant(setup))
    ctrl = make_controller(setup, model, 1e-3)
    samples = []
    for k in range(n):
        t = k * 1e-3
        s = math.sin(2 * math.pi * t)
        samples.append((t, {"position_m": 0.025 + 0.002 * s, "velocity_m_s": 0.0126 * math.cos(2 * math.pi * t),
                            "acceleration_m_s2": -0.08 * s, "force_N": 10 * s,
                            "pressure_valve_1_Pa": 3e5 + 5e4 * s, "pressure_valve_2_Pa": 3e5 - 5e4 * s,
                            "pressure_chamber_1_Pa": 3e5, "pressure_chamber_2_Pa": 3e5}))
    for t, m in samples[:200]:     # JIT warm-up
        ctrl(t, m)
    start = time.perf_counter()
    for t, m in samples:
        ctrl(t, m)
    return (time.perf_counter() - start) / n * 1e6


def main() -> None:
    if hasattr(os, "sched_setaffinity"):
        os.sched_setaffinity(0, {min(os.sched_getaffinity(0))})
    costs = {c: statistics.median(step_cost(c) for _ in range(5)) for c in CONTROLLERS}
    controller_study(duration_s=4.0, lengths=(2.0,), references=("sine:2Hz",))   # warm-up
    start = time.perf_counter()
    res = controller_study()
    study = time.perf_counter() - start
    print(json.dumps({"benchmark": "pneumatic_loop", "step_us": round(max(costs.values()), 2),
                      "step_us_by_controller": {k: round(v, 2) for k, v in costs.items()},
                      "chapter5_study_s": round(study, 2), "chapter5_runs": len(CH5_CONTROLLERS) * len(res["rows"]),
                      "limits": {"step_us": 5, "chapter5_study_s": 180}}))


if __name__ == "__main__":
    main()
