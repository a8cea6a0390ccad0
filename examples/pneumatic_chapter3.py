"""Chapter III side by side: Table 2 (exit Mach, adiabatic temperature drop), Table 3
(Richer-Hurmuzlu attenuation) and the fixed-volume pressurisation of Figures 4-7 and 10.

Run:  .venv/bin/python examples/pneumatic_chapter3.py [OUT_DIR] [--quiet]
Prints the tables, the valve-chamber gaps of Figures 4-7, the RMS error of each reduced 7.25 m
model against the distributed line per excitation (Figure 10; the thesis' own preliminary model,
eqs 7-13, is the primary row, chapter V's two-volume line a named extension), the thesis'
section 3.3 statements checked against those numbers with their criteria, and writes
OUT_DIR/chapter3_fixed_volume.png (rows: step, 2, 5, 10 Hz; columns: no line, 7.25 m line,
models vs distributed).
"""
import math
import sys
from pathlib import Path

import numpy as np
from matplotlib.figure import Figure

from geometry.atomic import save_figure
from sensor.pneumatic.air import AIR
from sensor.pneumatic.cylinder import FixedChambers
from sensor.pneumatic.line_plots import MODEL_COLOURS
from sensor.pneumatic.lines import (
    DeadVolume,
    Distributed,
    Preliminary,
    RicherHurmuzlu,
    TwoVolume,
    attenuation_factor,
    tube_resistance,
)
from sensor.pneumatic.plant import Plant
from sensor.pneumatic.sensors import ideal_sensors
from sensor.pneumatic.simulate import simulate
from sensor.cli.progress import counting

BORE = 0.004
# Table 2 of the thesis: length (m), final velocity (m/s), Mach, temperature (K), drop (%)
TABLE2 = [(8, 112.8469199, 0.328999767, 286.7914893, 2.118945635),
          (6, 130.675406, 0.38097786, 284.734492, 2.820992498),
          (3, 167.5320833, 0.48843173, 279.6567084, 4.554024422),
          (1, 215.6718232, 0.628780826, 271.5293425, 7.327869437)]
# Table 3 (mass flow read as 1e-3 kg/s, DESIGN section 12): length, flow, R_t, attenuation
TABLE3 = [(1, 3.2e-3, 775.64, 0.5744), (3, 2.5e-3, 610.48, 0.1769),
          (6, 1.9e-3, 489.67, 0.0467), (8, 1.7e-3, 434.15, 0.0238)]


def table2() -> None:
    t0, k = 293.0, AIR.gamma          # the thesis' stagnation (room) temperature
    print("Table 2: exit Mach (eq 2) and adiabatic exit temperature (eq 3), T0 = 293 K")
    print(" L (m)  u (m/s)  Ma thesis  Ma here   T thesis  T here   drop thesis  drop here")
    for length, u, ma_t, temp_t, drop_t in TABLE2:
        ma = u / AIR.speed_of_sound
        temp = t0 / (1 + (k - 1) / 2 * ma**2)
        print(f"{length:5d} {u:8.2f} {ma_t:9.4f} {ma:9.4f} {temp_t:9.2f} {temp:8.2f} {drop_t:10.2f} % "
              f"{100 * (1 - temp / t0):7.2f} %")


def table3() -> None:
    print("\nTable 3: Richer-Hurmuzlu tube resistance (eq 5) and attenuation (eq 4)")
    print(" L (m)  m (kg/s)  Re      R_t thesis  R_t here  att. thesis  att. here (P = 1 atm)  P implied (kPa)")
    for length, m, rt_t, att_t in TABLE3:
        re = AIR.reynolds(m, BORE)
        rt = float(tube_resistance(m, BORE, AIR.viscosity_Pa_s))
        att = float(attenuation_factor(m, length, BORE, AIR.atmosphere_Pa, AIR))
        p_implied = rt_t * AIR.rt * length / (2 * AIR.speed_of_sound * -math.log(att_t))
        print(f"{length:5d} {m:9.1e} {re:7.0f} {rt_t:10.1f} {rt:9.1f} {att_t:11.4f} {att:12.4f} {p_implied / 1e3:20.1f}")


CHAMBER = FixedChambers(4.5e-5, 4.5e-5)  # about half the 7.25 m line's 91 cm^3 (section 3.3)
SUPPLY_PA = 6.0e5
DURATION_S = 1.0
# "No line": the valve's 10 cm fitting, modelled as a distributed line so that the valve-chamber
# gap is computed rather than zero by construction (as a dead volume would make it).
NO_LINE = Distributed(0.1, BORE, segments=5)
LONG = {"dead-volume": DeadVolume(7.25, BORE), "richer-hurmuzlu": RicherHurmuzlu(7.25, BORE),
        "preliminary": Preliminary(7.25, BORE), "two-volume": TwoVolume(7.25, BORE),
        "distributed": Distributed(7.25, BORE, segments=20)}
REDUCED = ("dead-volume", "preliminary", "two-volume", "richer-hurmuzlu")


def excitations() -> dict:
    """Full-scale valve commands of Figures 4-7 and 10: a step (pressurise 0.5 s, then vent) and
    2, 5, 10 Hz sinusoids."""
    inputs = {"step": lambda t, m: 1.0 if t < 0.5 else -1.0}
    for f in (2.0, 5.0, 10.0):
        inputs[f"{f:g} Hz"] = (lambda f: lambda t, m: math.sin(2 * math.pi * f * t))(f)
    return inputs


def _run(line, controller):
    cp = Plant(supply_Pa=SUPPLY_PA, line_1=line, line_2=line, actuator=CHAMBER).compile()
    ds = simulate(cp, controller, DURATION_S, sensors=ideal_sensors())
    return ds.time.values, ds.pressure_valve.sel(side=1).values, ds.pressure_chamber.sel(side=1).values


def _rms(x) -> float:
    return float(np.sqrt(np.mean(np.square(x))))


def _gain_lag(t, valve, chamber, f_Hz):
    """Chamber over valve pressure at the excitation frequency: (amplitude ratio, lag in deg),
    projected on sin/cos over the second half (whole periods, start-up transient excluded)."""
    keep = t >= DURATION_S / 2
    basis = np.exp(-2j * np.pi * f_Hz * t[keep])
    h = np.sum(chamber[keep] * basis) / np.sum(valve[keep] * basis)
    return abs(h), -math.degrees(np.angle(h))


def fixed_volume(out_dir: Path, quiet: bool = False) -> None:
    inputs = excitations()
    setups = {"no line": NO_LINE, **LONG}
    runs = {name: {} for name in inputs}
    with counting("chapter III", quiet) as progress:
        for i, (name, setup) in enumerate((n, s) for n in inputs for s in setups):
            runs[name][setup] = _run(setups[setup], inputs[name])
            progress(i + 1, len(inputs) * len(setups), f"{name} {setup}")
    print(f"\nFixed-volume pressurisation (Figures 4-7, 10): Festo-like valve, {SUPPLY_PA / 1e5:g} bar abs "
          f"supply, {CHAMBER.volume_1_m3 * 1e6:g} cm^3 chamber, {BORE * 1e3:g} mm line, {DURATION_S:g} s runs")

    print("\nFigures 4-7: valve vs chamber pressure (RMS gap over the run; gain and lag of the chamber "
          "on the valve\npressure at the excitation frequency, second half of the run)")
    print(" input    | no line (10 cm)                     | 7.25 m (distributed line)")
    print("          | gap (kPa)  gap/swing  gain   lag    | gap (kPa)  gap/swing  gain   lag")
    gaps = {}
    for name, r in runs.items():
        cells = []
        for setup in ("no line", "distributed"):
            t, pv, pc = r[setup]
            gap = _rms(pv - pc)
            gaps[name, setup] = gap / np.ptp(pc)
            gl = f"{'-':>6s} {'-':>5s}    " if name == "step" else "{:6.2f} {:5.0f} deg".format(
                *_gain_lag(t, pv, pc, float(name.split()[0])))
            cells.append(f"{gap / 1e3:9.1f}  {100 * gaps[name, setup]:8.1f} %  {gl}")
        print(f" {name:8s} | {cells[0]:35s} | {cells[1]}")

    print("\nFigure 10: chamber pressure of each reduced 7.25 m model against the distributed line "
          "(RMS error over the run,\nkPa, and as % of the distributed chamber's peak-to-peak swing)")
    print(" input    " + "".join(f"| {m:>20s} " for m in REDUCED) + "| prelim./dead  two-vol./dead")
    errors = {}
    for name, r in runs.items():
        ref = r["distributed"][2]
        row = f" {name:8s} "
        for m in REDUCED:
            e = _rms(r[m][2] - ref)
            errors[name, m] = (e, e / np.ptp(ref))
            row += f"| {e / 1e3:8.1f} kPa {100 * e / np.ptp(ref):6.1f} % "
        print(row + "| " + "  ".join(f"{errors[name, m][0] / errors[name, 'dead-volume'][0]:12.2f}"
                                     for m in ("preliminary", "two-volume")))
    verdicts(inputs, gaps, errors)
    plot_grid(runs, out_dir)


def verdicts(inputs, gaps, errors) -> None:
    """The thesis' statements of section 3.3 against the numbers above, each with its criterion;
    the Figure 10 claims are judged for the thesis' preliminary model (eqs 7-13) first and then for
    the two-volume line of chapter V as a named extension."""
    sines = [n for n in inputs if n != "step"]
    no_line = max(gaps[n, "no line"] for n in inputs)
    long_2hz = gaps["2 Hz", "distributed"]
    grows = lambda xs: all(b > a for a, b in zip(xs, xs[1:]))  # noqa: E731

    def say(ok: bool, claim: str, rule: str, here: str) -> None:
        print(f" [{'agrees' if ok else 'disagrees'}] thesis: {claim}\n      criterion: {rule}\n           here: {here}")

    print("\nThesis section 3.3 statements vs this simulation")
    say(no_line < 0.05, "no line: valve and chamber pressures show no significant dynamic difference up "
        "to 10 Hz (Figs 4-5)", "largest RMS gap < 5 % of the chamber swing",
        f"largest valve-chamber RMS gap {100 * no_line:.1f} % of the chamber swing")
    say(long_2hz > 0.10, "7.25 m: the line limits the bandwidth; the valve-chamber difference is "
        "significant even at 2 Hz (Figs 6-7)", "RMS gap at 2 Hz > 10 % of the chamber swing",
        f"RMS gap at 2 Hz {100 * long_2hz:.0f} % of the chamber swing, "
        + ", ".join(f"{n} {100 * gaps[n, 'distributed']:.0f} %" for n in sines[1:]))
    for model, row in (("preliminary", "thesis' preliminary model, eqs 7-13"),
                       ("two-volume", "extension: chapter V's two-volume line, eqs 54-58")):
        ratio = [errors[n, model][0] / errors[n, "dead-volume"][0] for n in inputs]
        margin_abs = [errors[n, "dead-volume"][0] - errors[n, model][0] for n in inputs]
        at_5 = errors["5 Hz", model][1]
        print(f" -- Figure 10 with the {row}")
        say(max(ratio) < 0.8, "the preliminary model estimates the chamber pressure significantly better "
            "than the conventional model (Fig 10)", "RMS error ratio to the dead volume < 0.8 at every input",
            "ratio " + ", ".join(f"{n} {r:.2f}" for n, r in zip(inputs, ratio)))
        say(grows(margin_abs[:3]), "their difference increases with the excitation frequency (step, 2, 5 Hz)",
            "dead-volume minus model RMS error strictly increasing over step, 2, 5 Hz",
            ", ".join(f"{n} {m / 1e3:.1f} kPa" for n, m in zip(inputs, margin_abs)))
        say(at_5 < 0.10, "the new model keeps its accuracy at 5 Hz", "RMS error at 5 Hz < 10 % of the swing",
            f"{100 * at_5:.1f} % of the chamber swing")


def plot_grid(runs, out_dir: Path) -> None:
    """Rows: step, 2, 5, 10 Hz.  Columns: no line (Figs 4-5), 7.25 m distributed line (Figs 6-7),
    the 7.25 m chamber pressure of each model (Fig 10).  Dashed: the supply pressure."""
    fig = Figure(figsize=(14, 11))
    axes = fig.subplots(len(runs), 3, sharex=True, sharey=True)
    for row, (name, r) in zip(axes, runs.items()):
        for ax, setup in zip(row[:2], ("no line", "distributed")):
            t, pv, pc = r[setup]
            ax.plot(t, pv / 1e5, "k:", label="valve port")
            ax.plot(t, pc / 1e5, color="tab:blue", label="chamber")
        for m in ("distributed", *REDUCED):
            t, _, pc = r[m]
            row[2].plot(t, pc / 1e5, color=MODEL_COLOURS[m], lw=2.2 if m == "distributed" else 1.2,
                        label=f"chamber, {m}")
        for ax in row:
            ax.axhline(SUPPLY_PA / 1e5, color="0.5", ls="--", lw=0.8)
        row[0].set_ylabel(f"{name}\nP (bar abs)")
    for ax, title in zip(axes[0], ("no line (10 cm fitting): Figs 4-5", "7.25 m line: Figs 6-7",
                                   "7.25 m chamber, models vs distributed: Fig 10")):
        ax.set_title(title, fontsize=10)
    for ax in axes[-1]:
        ax.set_xlabel("time (s)")
    axes[0, 0].legend(fontsize=7)
    axes[0, 2].legend(fontsize=7)
    fig.tight_layout()
    target = out_dir / "chapter3_fixed_volume.png"
    save_figure(fig, target)
    print(f"\nwrote {target}")


def main() -> None:
    args = [a for a in sys.argv[1:] if a != "--quiet"]
    out_dir = Path(args[0]) if args else Path("pneumatic-out")
    out_dir.mkdir(parents=True, exist_ok=True)
    table2()
    table3()
    fixed_volume(out_dir, "--quiet" in sys.argv)


if __name__ == "__main__":
    main()
