"""Datasheets of the three thesis specimens as cut (Table 7 hinges), their cross-axis
sensitivity, and a picture of their calibration loops (like thesis Figures 43 and 45).

Also shows the basis body in ABS (thesis Figures 44-45). The fiber sits at the default
1.2 mm from the mirror, so the 1 mm full scale spans the thesis' 0.2-1.2 mm interval.

    python examples/sensor_datasheets.py [--out sensor-specimens.png] [--quiet]

About 5 s (2-core machine); a progress line shows on a terminal unless --quiet.
"""

from __future__ import annotations

import argparse

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

from geometry.atomic import save_figure  # noqa: E402
from geometry.params import MATERIALS, preset  # noqa: E402
from sensor.cli.progress import add_quiet_argument, busy  # noqa: E402
from sensor.mechanics.hysteresis import TABLE6  # noqa: E402
from sensor.readout.datasheet import cross_axis, datasheet  # noqa: E402
from sensor.readout.sensor_model import build_sensor, loading_cycle  # noqa: E402

SPECIMENS = ("basis", "sample-a", "sample-b")


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", default="sensor-specimens.png")
    add_quiet_argument(parser)
    args = parser.parse_args()
    with busy("sensor_datasheets", args.quiet) as step:
        fig = _datasheets(step)
    fig.tight_layout()
    save_figure(fig, args.out)
    print(f"wrote {args.out}")
    return 0


def _datasheets(step):

    designs = [preset(f"{n}-as-cut") for n in SPECIMENS]
    designs.append(preset("basis-as-cut").replace(material=MATERIALS["abs"], name="basis-as-cut-abs"))
    print(f"{'design':24s} {'range N':>8s} {'mV/N':>7s} {'res mN':>7s} {'nonlin %':>9s} "
          f"{'hyst %':>7s} {'H mech %':>8s} {'quality':>8s} {'cross %':>8s} {'at mm':>6s}")
    fig, axes = plt.subplots(1, 3, figsize=(12, 3.6))
    for d in designs:
        step(d.name)
        s = build_sensor(d)
        ds = datasheet(s, d.material.name)
        c = cross_axis(d, s.input_travel_mm)
        print(f"{d.name:24s} {ds.range_N:8.3f} {ds.sensitivity_mV_per_N:7.1f} "
              f"{ds.resolution_N * 1e3:7.3f} {ds.nonlinearity_pct:9.2f} {ds.hysteresis_pct:7.2f} "
              f"{ds.hysteresis_mechanical_pct:8.2f} {ds.quality_mV_per_N:8.0f} "
              f"{c.ratio_pct:8.3f} {c.imposed_travel_mm:6.3f}")
        base = d.name.removesuffix("-as-cut")
        if base in SPECIMENS:
            ax = axes[SPECIMENS.index(base)]
            n = len(s.calibration.force_table)
            r = s.read(loading_cycle(s.range_N, n))
            ax.plot(r.force_N[:n], r.volts[:n], color="tab:blue", label="loading")
            ax.plot(r.force_N[n - 1:], r.volts[n - 1:], color="tab:red", label="unloading")
            ax.set(xlabel="force (N)", ylabel="output (V)",
                   title=f"{d.name}: H {ds.hysteresis_pct:.1f} %, {ds.sensitivity_mV_per_N:.0f} mV/N")
            ax.legend(fontsize=8, loc="upper left")
    print("Table 6 measured quality (mm/N): "
          + ", ".join(f"{n} {TABLE6[n].quality:.2f}" for n in SPECIMENS))
    step("cross-axis of the basis body")
    for lateral in (1.0,):
        c = cross_axis(preset("basis-as-cut"), lateral)
        print(f"basis-as-cut at {lateral} mm imposed travel (the thesis protocol): cross-axis "
              f"{c.ratio_pct:.2f} % (+x {c.lateral_mirror_travel_mm[0] * 1e3:.1f} um, "
              f"-x {c.lateral_mirror_travel_mm[1] * 1e3:.1f} um, lateral force "
              f"{c.lateral_force_N:.3f} N); thesis 1.66 % delrin, 3.29 % ABS")
    return fig


if __name__ == "__main__":
    raise SystemExit(main())
