"""Chapter III side by side: Table 2 (exit Mach, adiabatic temperature drop), Table 3
(Richer-Hurmuzlu attenuation) and the fixed-volume pressurisation of Figures 4-7 and 10.

Run:  .venv/bin/python examples/pneumatic_chapter3.py [OUT_DIR]
Prints the tables and model errors and writes OUT_DIR/chapter3_fixed_volume.png.
"""
import math
import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

from geometry.atomic import atomic_path  # noqa: E402
from sensor.pneumatic.air import AIR  # noqa: E402
from sensor.pneumatic.cylinder import FixedChambers  # noqa: E402
from sensor.pneumatic.lines import DeadVolume, Distributed, TwoVolume, attenuation_factor, tube_resistance  # noqa: E402
from sensor.pneumatic.plant import Plant  # noqa: E402
from sensor.pneumatic.sensors import ideal_sensors  # noqa: E402
from sensor.pneumatic.simulate import simulate  # noqa: E402

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


def fixed_volume(out_dir: Path) -> None:
    chamber = FixedChambers(4.5e-5, 4.5e-5)   # about half the 7.25 m line volume (section 3.3)
    cases = {"no line": DeadVolume(0.0), "dead volume 7.25 m": DeadVolume(7.25),
             "two-volume 7.25 m": TwoVolume(7.25), "distributed 7.25 m": Distributed(7.25, segments=20)}
    inputs = {"step": lambda t, m: 1.0 if t < 0.5 else -1.0}
    for f in (2.0, 5.0, 10.0):
        inputs[f"{f:g} Hz"] = (lambda f: lambda t, m: math.sin(2 * math.pi * f * t))(f)
    fig, axes = plt.subplots(len(inputs), 1, figsize=(8, 11), sharex=False)
    print("\nFixed-volume pressurisation (Festo-like valve, 6 bar abs supply, 45 cm^3 chamber)")
    print(" input    model                chamber RMS error vs distributed (kPa)   valve-chamber RMS gap (kPa)")
    for ax, (name, ctrl) in zip(axes, inputs.items()):
        runs = {}
        for label, line in cases.items():
            cp = Plant(supply_Pa=6e5, line_1=line, line_2=line, actuator=chamber).compile()
            runs[label] = simulate(cp, ctrl, 1.0, sensors=ideal_sensors())
        ref = runs["distributed 7.25 m"].pressure_chamber.sel(side=1)
        for label, ds in runs.items():
            pc = ds.pressure_chamber.sel(side=1)
            gap = float(((ds.pressure_valve.sel(side=1) - pc) ** 2).mean() ** 0.5) / 1e3
            err = float(((pc - ref) ** 2).mean() ** 0.5) / 1e3
            print(f" {name:8s} {label:20s} {err:12.1f} {gap:38.1f}")
            ax.plot(ds.time, pc / 1e5, label=f"chamber, {label}")
        ax.plot(ref.time, runs["distributed 7.25 m"].pressure_valve.sel(side=1) / 1e5, "k:", label="valve port, distributed")
        ax.set_title(f"valve input: {name}")
        ax.set_ylabel("P (bar abs)")
    axes[-1].set_xlabel("time (s)")
    axes[0].legend(fontsize=7, ncol=2)
    fig.tight_layout()
    target = out_dir / "chapter3_fixed_volume.png"
    with atomic_path(target) as tmp:
        fig.savefig(tmp, dpi=110)
    print(f"\nwrote {target}")


def main() -> None:
    out_dir = Path(sys.argv[1]) if len(sys.argv) > 1 else Path("pneumatic-out")
    out_dir.mkdir(parents=True, exist_ok=True)
    table2()
    table3()
    fixed_volume(out_dir)


if __name__ == "__main__":
    main()
