"""Chapter IV side by side: pressure estimation of the force-feedback observer vs the standard
model vs the valve-port pressures (Figures 16-18, eq 44), SMC impedance control with the observer
vs open-loop estimation (Figure 26) and the switch-on transient (Figure 27), on the simulated
high-fidelity plant (7.25 m distributed lines).

Run:  .venv/bin/python examples/pneumatic_chapter4.py [OUT_DIR]
Prints the tables and, for each thesis claim, whether the simulation agrees; writes the figures.
"""
import sys
from pathlib import Path

from sensor.cli.loop import observer_figures
from sensor.pneumatic.studies import observer_study, observer_tables


def verdicts(t: dict) -> list[str]:
    est = {(r["experiment"], r["observer"]): r["pressure_mse_kPa2"] for r in t["estimation"]}
    out = []
    for exp in ("pi sine:1Hz", "pi sine:2Hz", "impedance square:0.5Hz"):
        o, s, v = est[(exp, "force")], est[(exp, "standard")], est[(exp, "valve")]
        ok = o < s and o < v
        out.append(f"{'AGREES' if ok else 'DISAGREES'}: {exp}: observer {o:.3g} kPa^2 vs standard {s:.3g}, "
                   f"valve {v:.3g} (thesis: observer far below both)")
    grow = est[("pi sine:2Hz", "standard")] > est[("pi sine:1Hz", "standard")] and \
        est[("pi sine:2Hz", "valve")] > est[("pi sine:1Hz", "valve")]
    out.append(f"{'AGREES' if grow else 'DISAGREES'}: standard-model and valve errors grow from 1 to 2 Hz")
    smc = {(r["experiment"].split()[-1], r["observer"]): r for r in t["smc"]}
    for f in ("sine:0.5Hz", "sine:1Hz", "sine:1.5Hz"):
        a, b = smc[(f, "force")], smc[(f, "standard")]
        gain = 100 * (1 - a["force_mse_N2"] / b["force_mse_N2"])
        pgain = 100 * (1 - a["pressure_mse_kPa2"] / b["pressure_mse_kPa2"])
        ok = gain > 5
        out.append(f"{'AGREES' if ok else 'DISAGREES'}: SMC impedance {f}: observer lowers force MSE by {gain:.0f} % "
                   f"(thesis ~25 % at 1.5 Hz) and pressure MSE by {pgain:.0f} %")
    return out


def main() -> None:
    out = Path(sys.argv[1]) if len(sys.argv) > 1 else Path("dacm-out")
    out.mkdir(parents=True, exist_ok=True)
    res = observer_study()
    print(observer_tables(res))
    for line in verdicts(res["tables"]):
        print(line)
    for f in observer_figures(res, out):
        print("wrote", f)


if __name__ == "__main__":
    main()
