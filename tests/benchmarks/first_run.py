"""Benchmark: the first `dacm sweep` after an install against the next ones.

numba compiles the solver's kernels on first use and caches them on disk; `make setup`
compiles them (its KERNELS step runs WARM_COMMAND once after installing). Each round gives
numba an empty cache directory (NUMBA_CACHE_DIR, a fresh install's state: the project's
own cache is not touched) and matplotlib an empty config directory (MPLCONFIGDIR: its
font list is built on first use, as on a new machine), runs the setup step, then the default `dacm sweep` twice: the
first is the cold run a new user gets, the second a warm one. One more fresh cache shows the
cold sweep without the setup step. Prints one JSON object: wall and CPU time (user +
system of the command and its workers) of each, medians over ROUNDS, and the ratios
cold / warm (target <= 1.5) and no-setup / warm. About 3 minutes on 2 quiet cores.

Run from the repository root: python -m tests.benchmarks.first_run
"""

import json
import os
import statistics
import tempfile

from tests.benchmarks.sweep import command_usage

#: What `make setup` runs to compile the kernels (Makefile: KERNELS).
WARM_COMMAND = ("solve", "--preset", "sample-b")
ROUNDS = 2


def main():
    out = {"load_average_before": os.getloadavg()}
    runs = {"setup": [], "cold": [], "warm": []}
    with tempfile.TemporaryDirectory() as tmp:
        sweep = ("sweep", "--out", os.path.join(tmp, "out"), "--quiet", "--force")
        for r in range(ROUNDS + 1):
            env = {**os.environ, "NUMBA_CACHE_DIR": os.path.join(tmp, f"cache{r}"),
                   "MPLCONFIGDIR": os.path.join(tmp, f"matplotlib{r}")}
            if r == ROUNDS:
                no_setup = command_usage(*sweep, env=env)
                break
            runs["setup"].append(command_usage(*WARM_COMMAND, env=env))
            runs["cold"].append(command_usage(*sweep, env=env))
            runs["warm"].append(command_usage(*sweep, env=env))
    for k, v in runs.items():
        out[f"{k}_wall_s"] = round(statistics.median(x[0] for x in v), 2)
        out[f"{k}_cpu_s"] = round(statistics.median(x[2] for x in v), 2)
    out["no_setup_wall_s"], out["no_setup_cpu_s"] = round(no_setup[0], 2), round(no_setup[2], 2)
    out["cold_over_warm_wall"] = round(out["cold_wall_s"] / out["warm_wall_s"], 2)
    out["cold_over_warm_cpu"] = round(out["cold_cpu_s"] / out["warm_cpu_s"], 2)
    out["no_setup_over_warm_wall"] = round(out["no_setup_wall_s"] / out["warm_wall_s"], 2)
    out["target_cold_over_warm"] = 1.5
    out["load_average_after"] = os.getloadavg()
    print(json.dumps(out))


if __name__ == "__main__":
    main()
