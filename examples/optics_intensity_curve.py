"""Output voltage against fiber-mirror gap with the working range marked (thesis Figure 62).

Left: both intensity models for the default setup (0.9 mm core, NA 0.5, 5 mW source), each
with its widest interval within the nonlinearity tolerance shaded, and the thesis' 0.2-1.2 mm
interval dashed. Right: how linear the thesis' intervals are against the effective NA (a
laser launch under-fills a plastic fiber's modes, so its effective NA is below the rated
one). Prints the numbers.

    python examples/optics_intensity_curve.py [--out optics_intensity_curve.png] [--tol 1] [--quiet]

About 18 s (2-core machine); a progress line shows on a terminal unless --quiet.
"""

from __future__ import annotations

import argparse
import dataclasses

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from geometry.atomic import save_figure  # noqa: E402
from sensor.cli.progress import add_quiet_argument, busy  # noqa: E402
from sensor.readout.noise import gap_resolution_mm, noise_rms_V  # noqa: E402
from sensor.readout.optics import (  # noqa: E402
    MODELS,
    OpticsSetup,
    linearity,
    output_voltage,
    working_range,
)

THESIS_INTERVALS = ((0.2, 1.2), (0.1, 1.5))
COLORS = {"geometric": "tab:blue", "gaussian": "tab:orange"}


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", default="optics_intensity_curve.png")
    parser.add_argument("--tol", type=float, default=1.0, help="nonlinearity tolerance, %% FS")
    add_quiet_argument(parser)
    args = parser.parse_args()
    with busy("optics_intensity_curve", args.quiet) as step:
        fig = _figure(args, step)
    save_figure(fig, args.out)
    print(f"wrote {args.out}")
    return 0


def _figure(args, step):

    setup = OpticsSetup()
    gaps = np.linspace(0.0, 3.0, 601)
    fig, (ax, ax_na) = plt.subplots(1, 2, figsize=(12, 4.8))
    for model in MODELS:
        step(f"{model} model: working range")
        wr = working_range(setup, args.tol, model)
        ax.plot(gaps, output_voltage(gaps, setup, model), color=COLORS[model], label=model)
        ax.axvspan(wr.gap_lo_mm, wr.gap_hi_mm, color=COLORS[model], alpha=0.15,
                   label=f"{model}: {wr.gap_lo_mm:.2f}-{wr.gap_hi_mm:.2f} mm within "
                         f"{args.tol:g} % FS, {wr.slope_V_per_mm:.2f} V/mm")
        noise = float(noise_rms_V(setup, 500.0, 0.5 * (wr.gap_lo_mm + wr.gap_hi_mm), model))
        res = float(gap_resolution_mm(setup, 500.0, 0.5 * (wr.gap_lo_mm + wr.gap_hi_mm), model))
        print(f"{model:9s} working range ({args.tol:g} % FS, best-fit line): "
              f"{wr.gap_lo_mm:.3f}-{wr.gap_hi_mm:.3f} mm, slope {wr.slope_V_per_mm:.3f} V/mm, "
              f"nonlinearity {wr.nonlinearity_pct:.2f} %; noise at mid-range "
              f"{noise * 1e6:.2f} uV RMS in 500 Hz (ratio readout) = {res * 1e6:.2f} nm")
        for lo, hi in THESIS_INTERVALS:
            fit, chord = (linearity(lo, hi, setup, model, line)
                          for line in ("best_fit", "endpoint"))
            print(f"{'':9s} thesis {lo}-{hi} mm: nonlinearity {fit.nonlinearity_pct:.1f} % FS "
                  f"(best fit), {chord.nonlinearity_pct:.1f} % FS (endpoint); "
                  f"slope {fit.slope_V_per_mm:.3f} V/mm")
    for x in THESIS_INTERVALS[0]:
        ax.axvline(x, color="k", ls="--", lw=1)
    ax.set(xlabel="mirror-fiber gap (mm)", ylabel="output voltage (V)",
           title="Single-fiber intensity vs gap (dashed: thesis 0.2-1.2 mm)")
    ax.legend(fontsize=8)

    nas = np.linspace(0.1, 0.6, 26)
    for model in MODELS:
        step(f"{model} model: nonlinearity against NA")
        for (lo, hi), style in zip(THESIS_INTERVALS, ("-", ":")):
            pct = [linearity(lo, hi, dataclasses.replace(setup, numerical_aperture=na), model,
                             step_mm=0.005).nonlinearity_pct for na in nas]
            ax_na.plot(nas, pct, style, color=COLORS[model], label=f"{model}, {lo}-{hi} mm")
    ax_na.axhline(args.tol, color="k", lw=0.8)
    ax_na.set(xlabel="effective numerical aperture", ylabel="nonlinearity (% FS, best-fit line)",
              yscale="log", title="How linear are the thesis intervals?")
    ax_na.legend(fontsize=8)
    fig.tight_layout()
    return fig


if __name__ == "__main__":
    raise SystemExit(main())
