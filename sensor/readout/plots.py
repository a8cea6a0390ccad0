"""Figures of a sensor model: intensity against gap and the calibration cycle.

Each function returns a ``matplotlib.figure.Figure`` (no pyplot state, no backend choice);
the caller writes it (``geometry.atomic.save_figure``).
"""

from __future__ import annotations

import numpy as np
from matplotlib.figure import Figure

from geometry import style
from sensor.readout.datasheet import Datasheet
from sensor.readout.optics import output_voltage, working_range
from sensor.readout.sensor_model import SensorModel, loading_cycle

style.use()


def intensity_figure(sensor: SensorModel, ds: Datasheet, tolerance_pct: float) -> Figure:
    """Output voltage against mirror-fiber gap (cf. thesis Figure 62), with the widest gap
    interval where V(gap) stays within ``tolerance_pct`` % of its span from a line (optics
    alone) and the sensor's own gap interval, labelled with the datasheet's nonlinearity
    (force to volts, :func:`~sensor.readout.datasheet.datasheet`): one number per sensor."""
    model = sensor.readout.model
    gaps = np.linspace(0.0, 3.0, 301)
    wr = working_range(sensor.optics, tolerance_pct, model, step_mm=0.01)
    fig = Figure(figsize=(6.4, 4.2), layout="tight")
    ax = fig.subplots()
    ax.plot(gaps, output_voltage(gaps, sensor.optics, model), color="k", lw=1.5,
            label=f"{model} model, NA {sensor.optics.numerical_aperture:g}, "
                  f"core {sensor.optics.core_diameter_mm:g} mm")
    ax.axvspan(wr.gap_lo_mm, wr.gap_hi_mm, color="tab:green", alpha=0.15,
               label=f"optics alone, widest gap interval with V(gap) within {tolerance_pct:g} % "
                     f"of a line: {wr.gap_lo_mm:.2f}-{wr.gap_hi_mm:.2f} mm")
    for x in (ds.gap_min_mm, ds.gap_max_mm):
        ax.axvline(x, color="tab:red", ls="--", lw=1)
    ax.plot([], [], color="tab:red", ls="--",
            label=f"sensor's gap range {ds.gap_min_mm:.2f}-{ds.gap_max_mm:.2f} mm: "
                  f"nonlinearity {ds.nonlinearity_pct:.2f} % FS (datasheet)")
    ax.set(xlabel="mirror-fiber gap (mm)", ylabel="output voltage (V)",
           title=f"{sensor.name}: intensity vs gap (cf. thesis Figure 62)")
    ax.legend(fontsize=8)
    return fig


def calibration_figure(sensor: SensorModel, ds: Datasheet) -> Figure:
    """The simulated loading-unloading cycle (cf. thesis Figures 43, 45) and the reading error."""
    cal = sensor.calibration
    n = len(cal.force_table)
    r = sensor.read(loading_cycle(sensor.range_N, n))
    fig = Figure(figsize=(10, 4.2), layout="tight")
    ax, ax_err = fig.subplots(1, 2)
    ax.plot(r.force_N[:n], r.volts[:n], color="tab:blue", label="loading")
    ax.plot(r.force_N[n - 1:], r.volts[n - 1:], color="tab:red", label="unloading")
    f = np.array([0.0, sensor.range_N])
    ax.plot(f, (f - cal.intercept_N) / cal.slope_N_per_V, "k--", lw=1,
            label=f"least squares: {ds.sensitivity_mV_per_N:.1f} mV/N")
    ax.set(xlabel="applied force (N)", ylabel="sensor output (V)",
           title=f"{sensor.name}: calibration (cf. thesis Figures 43, 45)")
    ax.text(0.97, 0.05, f"hysteresis {ds.hysteresis_pct:.2f} % FS\n"
                        f"nonlinearity {ds.nonlinearity_pct:.2f} % FS",
            transform=ax.transAxes, ha="right", va="bottom", fontsize=9)
    ax.legend(fontsize=8, loc="upper left")
    err = 1e3 * (r.newtons - r.force_N)
    ax_err.plot(r.force_N[:n], err[:n], color="tab:blue", label="loading")
    ax_err.plot(r.force_N[n - 1:], err[n - 1:], color="tab:red", label="unloading")
    ax_err.axhline(0.0, color="k", lw=0.6)
    ax_err.set(xlabel="applied force (N)", ylabel="reading - applied (mN)",
               title=f"reading error ({cal.method} calibration, {ds.adc_bits}-bit ADC)")
    ax_err.legend(fontsize=8)
    return fig
