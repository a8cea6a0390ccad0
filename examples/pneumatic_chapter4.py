"""Chapter IV side by side: pressure estimation of the force-feedback observer vs the open-loop
standard model vs the valve-port pressures (Figures 16-18, eq 44), SMC impedance control with
each estimator (Figure 26) and the switch-on transient (Figure 27), on the simulated
high-fidelity plant (7.25 m distributed lines), every run from the atmosphere and measured
by the status rule (sensor.pneumatic.loop_metrics.SETTLING_RULE).

Run:  .venv/bin/python examples/pneumatic_chapter4.py [OUT_DIR] [--quiet]
Prints the tables and, for each thesis claim, its verdict with the numeric criterion; writes
the figures.  Same numbers as `dacm loop --study observer`.
"""
import sys
from pathlib import Path

from geometry.atomic import save_figure
from sensor.pneumatic.plots import observer_phase_figure, observer_smc_figure
from sensor.cli.progress import counting
from sensor.pneumatic.studies import observer_study
from sensor.pneumatic.verdicts import observer_tables


def main() -> None:
    args = [a for a in sys.argv[1:] if a != "--quiet"]
    out = Path(args[0]) if args else Path("dacm-out")
    out.mkdir(parents=True, exist_ok=True)
    with counting("chapter IV", "--quiet" in sys.argv) as progress:
        res = observer_study(progress=progress)
    print(observer_tables(res))
    for name, make in (("loop-observer-phase.png", observer_phase_figure), ("loop-observer-smc.png", observer_smc_figure)):
        print("wrote", save_figure(make(res), out / name))


if __name__ == "__main__":
    main()
