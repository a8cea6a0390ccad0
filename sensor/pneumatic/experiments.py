"""Closed-loop experiments of chapters IV and V on the high-fidelity plant, and the DACM sensor
in the loop.

:func:`run` builds one experiment (plant, sensors, observer, controller), simulates it with the
fixed-rate harness and returns the harness' dataset with the controller's log added
(estimated pressures, desired force, virtual input, ...).  :func:`metrics` gives the figures
the thesis reports: the force-control MSE and the pressure-estimation MSE of eq 44 over the
steady window (the last two seconds of a periodic run; the two seconds from the step).

The studies (:func:`observer_study`, :func:`controller_study`, :func:`sensor_study`) run the
experiment grids of Figures 16-19 and 26-27, Table 4 and Figures 32-37, and the sensor-in-the-
loop comparison, and return tables (lists of dicts) next to the thesis' numbers and claims.

Rig: a 16 mm Airpel-like cylinder (plant default) on an attached 5 kN/m spring (the thesis'
"spring system ... proportional to the piston displacement"), both lines distributed (20
segments, frequency-dependent friction and heat transfer), 6 bar abs supply, default noisy
sensors (load cell, potentiometer, P51-class pressure transducers), 1 kHz loop.  The Festo
valve for section 4.2, the Enfield LH05 for section 4.3 and chapter V, as the thesis.  Plant
parameters are never adjusted to reach a thesis number.
"""
from __future__ import annotations

import math
import time
import warnings
from dataclasses import dataclass, field, replace

import numpy as np
import xarray as xr

from sensor.errors import SensorError
from sensor.pneumatic.controllers import (CONTROLLERS, Impedance, LineModel, PIForce, Reference, SlidingMode,
                                          parse_reference)
from sensor.pneumatic.cylinder import Environment, mass_spring_damper, spring_contact
from sensor.pneumatic.lines import make_line
from sensor.pneumatic.observer import OBSERVER_KINDS, ObserverModel, PressureObserver
from sensor.pneumatic.plant import Plant
from sensor.pneumatic.sensors import Sensors
from sensor.pneumatic.simulate import simulate
from sensor.pneumatic.valve import VALVES

MSE_WINDOW_S = 2.0       # thesis 5.4.2: "mean of error squares obtained in a 2-second time interval"
OBSERVER_RATE_HZ = 10.0  # correction pole at mid-stroke (k of eq 22 from it)


class CapacityWarning(UserWarning):
    """A reference asks for more force than the actuator (or sensor) can give."""


@dataclass(frozen=True)
class Setup:
    """One experiment.  ``reference`` like ``sine:1Hz``; ``amplitude_N``/``offset_N`` its size;
    ``environment``: the load (default: attached 5 kN/m spring at mid-stroke, 20 N s/m);
    ``gains``: keyword overrides for the controller; ``force_sensor``: an object with
    ``read(value, t)`` replacing the load cell (see :func:`dacm_force_sensor`)."""

    controller: str = "pi"
    observer: str = "force"
    reference: str = "sine:1Hz"
    amplitude_N: float = 24.0
    offset_N: float = 0.0
    line_length_m: float = 7.25
    line_model: str = "distributed"
    segments: int = 20
    valve: str = "festo-mpye-5-1/8-lf"
    duration_s: float = 6.0
    observer_rate_Hz: float = OBSERVER_RATE_HZ
    observer_on_s: float = 0.0
    environment: Environment = field(default_factory=lambda: mass_spring_damper(0.0, 5000.0, 20.0, 0.025))
    gains: tuple = ()
    force_sensor: object = None
    seed: int = 0

    def __post_init__(self) -> None:
        if self.controller not in CONTROLLERS:
            raise SensorError(f"controller = {self.controller!r}: must be one of {', '.join(CONTROLLERS)}")
        if self.observer not in OBSERVER_KINDS:
            raise SensorError(f"observer = {self.observer!r}: must be one of {', '.join(OBSERVER_KINDS)}")
        if self.valve not in VALVES:
            raise SensorError(f"valve = {self.valve!r}: must be one of {', '.join(VALVES)}")
        if not (math.isfinite(self.duration_s) and self.duration_s > 0):
            raise SensorError(f"duration = {self.duration_s!r} s: must be a positive finite number")

    @property
    def ref(self) -> Reference:
        return parse_reference(self.reference, self.amplitude_N, self.offset_N)


def build_plant(setup: Setup) -> Plant:
    opts = {"segments": setup.segments} if setup.line_model == "distributed" else {}
    line = make_line(setup.line_model, setup.line_length_m, 0.004, **opts)
    return Plant(valve=VALVES[setup.valve], line_1=line, line_2=line, environment=setup.environment)


def make_controller(setup: Setup, model: ObserverModel, dt_s: float):
    ref = setup.ref
    obs = PressureObserver(model, setup.observer, model.gain_for_rate(setup.observer_rate_Hz), dt_s,
                           gain_on_s=setup.observer_on_s)
    gains = dict(setup.gains)
    try:
        if setup.controller == "pi":
            return PIForce(model, ref, obs, dt_s, **gains)
        if setup.controller == "impedance":
            return Impedance(model, ref, obs, dt_s, **gains)
        if setup.controller == "smc":
            imp = gains.pop("impedance", None)
            return SlidingMode(model, ref, obs, dt_s, impedance=imp, **gains)
        return LineModel(model, ref, obs, dt_s, **gains)
    except TypeError as exc:
        raise SensorError(f"controller {setup.controller!r} gains {sorted(gains)}: {exc}") from None


def check_capacity(setup: Setup, model: ObserverModel) -> list[str]:
    """Warn (:class:`CapacityWarning`) when the reference leaves the force the actuator can make
    (eq 17 with one chamber at supply, the other at atmosphere), or the sensor's range."""
    lo, hi = model.force_capacity_N()
    rlo, rhi = setup.ref.peak_N
    if setup.controller == "impedance":
        return []
    msgs = []
    if rhi > hi or rlo < lo:
        msgs.append(f"reference spans [{rlo:.4g}, {rhi:.4g}] N: beyond the actuator's force capacity "
                    f"[{lo:.4g}, {hi:.4g}] N (supply {model.q[2] / 1e5:.3g} bar abs, eq 17)")
    rng = getattr(setup.force_sensor, "range_N", None)
    if rng is not None and (rlo < 0 or rhi > rng):
        msgs.append(f"reference spans [{rlo:.4g}, {rhi:.4g}] N: beyond the force sensor's range [0, {rng:.4g}] N")
    for msg in msgs:
        warnings.warn(msg, CapacityWarning, stacklevel=2)
    return msgs


def run(setup: Setup, rate_Hz: float = 1000.0) -> xr.Dataset:
    """Simulate one experiment; the dataset carries the harness' variables plus the controller's
    log (``desired_force_N``, ``estimated_pressure_1_Pa``, ...) and the setup in ``attrs``."""
    plant = build_plant(setup)
    model = ObserverModel.from_plant(plant)
    dt = 1.0 / rate_Hz
    ctrl = make_controller(setup, model, dt)
    check_capacity(setup, model)
    sensors = Sensors() if setup.force_sensor is None else Sensors(force=setup.force_sensor)
    ds = simulate(plant, ctrl, setup.duration_s, rate_Hz, sensors)
    rows = np.full((ds.sizes["time"], len(ctrl.channels)), np.nan)
    rows[:len(ctrl.rows)] = np.asarray(ctrl.rows, float)
    for j, name in enumerate(ctrl.channels):
        ds[name] = ("time", rows[:, j])
    z = ds.piston_position.values
    stroke = model.q[9]
    if np.any(z < 0) or np.any(z > stroke):
        warnings.warn(f"the piston reached an end stop (z from {z.min() * 1e3:.3g} to {z.max() * 1e3:.3g} mm, "
                      f"stroke {stroke * 1e3:.3g} mm): eq 18 then misses the stop force", CapacityWarning,
                      stacklevel=2)
    ds.attrs.update({"controller": setup.controller, "observer": setup.observer, "reference": setup.reference,
                     "amplitude_N": setup.amplitude_N, "line_length_m": setup.line_length_m})
    return ds


def window(ds: xr.Dataset, reference: Reference) -> slice:
    """The steady window: the last MSE_WINDOW_S of a periodic run, or MSE_WINDOW_S from a step."""
    end = float(ds.time[-1])
    if reference.kind == "step":
        return slice(reference.step_s, min(end, reference.step_s + MSE_WINDOW_S))
    period = 1.0 / reference.frequency_Hz
    span = max(period, math.floor(MSE_WINDOW_S / period) * period)
    return slice(end - span, end)


def metrics(ds: xr.Dataset, reference: Reference) -> dict:
    """Force-control MSE (N^2) and eq 44 pressure-estimation MSE, 1/2 mean(P~1^2 + P~2^2) in
    kPa^2, over the steady window; MSE_2 (virtual input) for the line-model controller."""
    w = ds.sel(time=window(ds, reference))
    w = w.isel(time=slice(0, -1)) if np.isnan(w.desired_force_N.values[-1]) else w
    e = w.desired_force_N - w.environment_force
    pt = np.stack([w.estimated_pressure_1_Pa - w.pressure_chamber.sel(side=1),
                   w.estimated_pressure_2_Pa - w.pressure_chamber.sel(side=2)])
    vt = np.stack([w.pressure_valve.sel(side=s) - w.pressure_chamber.sel(side=s) for s in (1, 2)])
    out = {"force_mse_N2": float((e**2).mean()), "pressure_mse_kPa2": float(0.5 * np.mean(np.sum(pt**2, 0)) / 1e6),
           "valve_pressure_mse_kPa2": float(0.5 * np.mean(np.sum(vt**2, 0)) / 1e6),
           "window_s": [float(w.time[0]), float(w.time[-1])]}
    if "virtual_input_N" in w:
        out["virtual_input_mse_N2"] = float(((w.virtual_input_desired_N - w.virtual_input_N) ** 2).mean())
        lt = np.stack([w.line_model_pressure_1_Pa - w.pressure_chamber.sel(side=1),
                       w.line_model_pressure_2_Pa - w.pressure_chamber.sel(side=2)])
        out["line_model_pressure_mse_kPa2"] = float(0.5 * np.mean(np.sum(lt**2, 0)) / 1e6)
    return out
