"""A solved body's force resolution as the sensor model's datasheet states it, from the
solve's own force-travel curve (no second solve, so a sweep can afford it for every cell).

The datasheet (:func:`sensor.readout.datasheet.datasheet`) states the RMS resolution as the
worst over the range of |dF/dV| sqrt(sigma^2 + q^2 / 12): sigma the RMS noise at the sample
rate, q the ADC step. With the default "curve" calibration F(V) is the mean of the loading
and unloading branches, and the Preisach loop of :mod:`sensor.readout.sensor_model` is
symmetric about the elastic curve x_e(F) (h = -/+ mu s(1 - s)), so dF/dV = (dF/dx_e) /
(dV/dx) with x the mirror travel and dV/dx = -dV/d(gap). Defaults: the thesis' bench optics
(:class:`~sensor.readout.optics.OpticsSetup`) and acquisition
(:class:`~sensor.readout.sensor_model.Readout`).
"""

from __future__ import annotations

import functools

import numpy as np
from scipy.interpolate import PchipInterpolator

from sensor.readout.noise import noise_rms_V
from sensor.readout.optics import OpticsSetup, voltage_slope
from sensor.readout.sensor_model import Readout

#: Stations along the travel where the worst resolution is looked for.
STATIONS = 129


def resolution_N(force_N, travel_mm, fiber_clearance_mm: float, optics: OpticsSetup = OpticsSetup(),
                 readout: Readout = Readout()) -> float:
    """RMS force resolution (N), the worst over the range, of a body whose mirror travels
    ``travel_mm`` under ``force_N`` (a solve's curve from the unloaded state, increasing)
    with the fiber ``fiber_clearance_mm`` from the mirror at rest; NaN for a failed solve."""
    return float(resolutions_N([(force_N, travel_mm)], [fiber_clearance_mm], optics, readout)[0])


def resolutions_N(curves, fiber_clearance_mm, optics: OpticsSetup = OpticsSetup(),
                  readout: Readout = Readout()) -> np.ndarray:
    """:func:`resolution_N` of many bodies: ``curves`` holds (force_N, travel_mm) pairs (None
    for a failed solve: NaN), ``fiber_clearance_mm`` one clearance each. Curves with the same
    travel stations (a sweep row's, under displacement control) share one interpolant."""
    out = np.full(len(curves), np.nan)
    forces: dict[int, np.ndarray] = {}
    groups: dict[tuple, list[int]] = {}   # (travel stations, clearance) -> curves
    for n, curve in enumerate(curves):
        if curve is None:
            continue
        f, x = np.asarray(curve[0], dtype=float), np.asarray(curve[1], dtype=float)
        if f.size < 2 or f.shape != x.shape or not (np.isfinite(f).all() and np.isfinite(x).all()) \
                or np.any(np.diff(x) <= 0):
            continue
        forces[n] = f
        groups.setdefault((x.tobytes(), float(fiber_clearance_mm[n])), []).append(n)
    for (stations, clearance), members in groups.items():
        x = np.frombuffer(stations)
        f = np.column_stack([forces[n] for n in members])
        x0, x1 = round(float(x[0]), 9), round(float(x[-1]), 9)  # one cache entry per travel
        dF_dx = PchipInterpolator(x, f, axis=0)(np.linspace(x0, x1, STATIONS), 1)   # (STATIONS, k)
        noise = _travel_noise_mm(clearance, x0, x1, optics, readout)
        out[members] = np.max(np.abs(dF_dx) * noise[:, None], axis=0)
    return out


@functools.lru_cache(maxsize=64)
def _travel_noise_mm(fiber_clearance_mm: float, x0: float, x1: float, optics: OpticsSetup,
                     readout: Readout) -> np.ndarray:
    """sqrt(sigma^2 + q^2 / 12) / |dV/dx| (mm RMS) at the stations from x0 to x1 (the optics
    are the same for every body of a sweep: computed once)."""
    gap = fiber_clearance_mm - np.linspace(x0, x1, STATIONS)
    sigma = noise_rms_V(optics, readout.bandwidth_Hz, gap, readout.model, readout.mode)
    out = np.sqrt(sigma**2 + readout.adc_step_V**2 / 12.0) / np.abs(voltage_slope(gap, optics, readout.model))
    out.flags.writeable = False
    return out
