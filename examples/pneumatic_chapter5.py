"""Chapter V side by side: the cascaded line-model controller vs the standard sliding-mode
controller on 2, 5, 7.25 and 10 m lines with step, 0.5, 1 and 2 Hz references (Table 4, Figure
32), the virtual-input tracking (Figures 33-34) and the chamber-pressure estimation of the line
model vs the standard model (Figure 37), on the simulated high-fidelity plant.  Gains per line
length as section 5.4.2, derived from the line's dynamics (smc_gains, line_model_gains in
sensor.pneumatic.controllers), the same for every reference on a length.

Run:  .venv/bin/python examples/pneumatic_chapter5.py [OUT_DIR]
Prints the tables, Table 4's numbers in brackets, and each thesis claim with the simulation's
verdict; writes the figures.
"""
import sys
from pathlib import Path

from sensor.cli.loop import controller_figures
from sensor.pneumatic.studies import CH5_REFERENCES, controller_study, controller_tables


def verdicts(rows: list[dict]) -> list[str]:
    get = {(r["line_length_m"], r["reference"], r["controller"]): r for r in rows}
    out = []
    best = 0.0
    for length in (5.0, 7.25, 10.0):
        for ref in ("sine:0.5Hz", "sine:1Hz", "sine:2Hz"):
            s, m = get[(length, ref, "smc")]["force_mse_N2"], get[(length, ref, "line-model")]["force_mse_N2"]
            red = 100 * (1 - m / s)
            best = max(best, red)
            out.append(f"{'AGREES' if m < s else 'DISAGREES'}: {length:g} m {ref}: line-model MSE_1 {m:.3g} vs SMC "
                       f"{s:.3g} N^2 ({red:+.0f} % reduction; thesis: line model better for 5-10 m)")
    out.append(f"{'AGREES' if best >= 75 else 'DISAGREES'}: largest reduction {best:.0f} % (thesis: up to 75 %)")
    for ref in ("sine:0.5Hz", "sine:1Hz", "sine:2Hz"):
        s, m = get[(2.0, ref, "smc")]["force_mse_N2"], get[(2.0, ref, "line-model")]["force_mse_N2"]
        out.append(f"{'AGREES' if s < m else 'DISAGREES'}: 2 m {ref}: SMC {s:.3g} vs line model {m:.3g} N^2 "
                   "(thesis: SMC better at 2 m)")
    mse2 = [get[(L, "sine:1Hz", "line-model")]["virtual_input_mse_N2"] for L in (2.0, 5.0, 7.25, 10.0)]
    flat = max(mse2) < 3 * min(mse2)
    out.append(f"{'AGREES' if flat else 'DISAGREES'}: MSE_2 at 1 Hz across lengths {[round(x, 2) for x in mse2]} "
               "(thesis: almost fixed across lengths)")
    pe = [(get[(L, "sine:2Hz", "line-model")]["line_model_pressure_mse_kPa2"],
           get[(L, "sine:2Hz", "line-model")]["pressure_mse_kPa2"]) for L in (2.0, 5.0, 7.25, 10.0)]
    ok = all(a < b for a, b in pe)
    out.append(f"{'AGREES' if ok else 'DISAGREES'}: 2 Hz pressure estimation, line model vs standard model (kPa^2): "
               f"{[(round(a, 1), round(b, 1)) for a, b in pe]} (thesis Figure 37: line model far better)")
    return out


def main() -> None:
    out = Path(sys.argv[1]) if len(sys.argv) > 1 else Path("dacm-out")
    out.mkdir(parents=True, exist_ok=True)
    keep = {(5.0, r, "line-model") for r in CH5_REFERENCES}
    res = controller_study(keep_runs=keep)
    print(controller_tables(res))
    for line in verdicts(res["rows"]):
        print(line)
    for f in controller_figures(res, out):
        print("wrote", f)


if __name__ == "__main__":
    main()
