"""Chapter V side by side: the thesis' cascaded line-model controller (eqs 63-72 as written,
k_m = 0, PI inner loop), our variant with line-flow damping k_m, and the standard sliding-mode
controller on 2, 5, 7.25 and 10 m lines with step, 0.5, 1 and 2 Hz references (Table 4,
Figure 32), the virtual-input tracking (Figures 33-34) and the chamber-pressure estimation of
the line model vs the standard model (Figure 37), on the simulated high-fidelity plant.  Gains
per line length by the thesis' tuning rule (section 5.4.2, sensor.pneumatic.tuning: the same
step settling time and overshoot for SMC and the line model), the fixed rules as alternative
rows; every run from the atmosphere, named settled, limit_cycle or unsettled.

Run:  .venv/bin/python examples/pneumatic_chapter5.py [OUT_DIR] [--quiet]
Prints the table with Table 4 beside it and each thesis claim's verdict with its numeric
criterion, first for the thesis' controller, then for ours; writes the figures.  Same
numbers as `dacm loop --study controllers`.
"""
import sys
from pathlib import Path

from geometry.atomic import save_figure
from sensor.pneumatic.plots import (
    controller_mse_figure,
    controller_virtual_input_figure,
)
from sensor.cli.progress import counting
from sensor.pneumatic.studies import controller_study
from sensor.pneumatic.verdicts import controller_tables


def main() -> None:
    args = [a for a in sys.argv[1:] if a != "--quiet"]
    out = Path(args[0]) if args else Path("dacm-out")
    out.mkdir(parents=True, exist_ok=True)
    keep = {(5.0, "sine:1Hz", k) for k in ("line_model_thesis", "line_model_damped")}
    with counting("chapter V", "--quiet" in sys.argv) as progress:
        res = controller_study(keep_runs=keep, progress=progress)
    print(controller_tables(res))
    print("wrote", save_figure(controller_mse_figure(res), out / "loop-controllers-mse.png"))
    print("wrote", save_figure(controller_virtual_input_figure(res), out / "loop-controllers-virtual-input.png"))


if __name__ == "__main__":
    main()
