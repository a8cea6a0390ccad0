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

import json
import math
import warnings
from dataclasses import dataclass, field, replace

import numpy as np
import xarray as xr

from sensor.errors import CapacityWarning, SensorInputError
from sensor.pneumatic.controllers import (
    CONTROLLERS,
    Impedance,
    LineModel,
    PIForce,
    Reference,
    SlidingMode,
    line_model_gains,
    parse_reference,
    smc_gains,
)
from sensor.pneumatic.cylinder import Environment, mass_spring_damper, spring_contact
from sensor.pneumatic.lines import make_line
from sensor.pneumatic.observer import OBSERVER_KINDS, ObserverModel, PressureObserver
from sensor.pneumatic.plant import Plant
from sensor.pneumatic.sensors import Sensors
from sensor.pneumatic.simulate import simulate
from sensor.pneumatic.valve import VALVES

MSE_WINDOW_S = 2.0       # thesis 5.4.2: "mean of error squares obtained in a 2-second time interval"
OBSERVER_RATE_HZ = 10.0  # correction pole at mid-stroke (k of eq 22 from it)


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
            raise SensorInputError(f"controller = {self.controller!r}: must be one of {', '.join(CONTROLLERS)}")
        if self.observer not in OBSERVER_KINDS:
            raise SensorInputError(f"observer = {self.observer!r}: must be one of {', '.join(OBSERVER_KINDS)}")
        if self.valve not in VALVES:
            raise SensorInputError(f"valve = {self.valve!r}: must be one of {', '.join(VALVES)}")
        if not (math.isfinite(self.duration_s) and self.duration_s > 0):
            raise SensorInputError(f"duration = {self.duration_s!r} s: must be a positive finite number")

    @property
    def ref(self) -> Reference:
        return parse_reference(self.reference, self.amplitude_N, self.offset_N)


def build_plant(setup: Setup) -> Plant:
    opts = {"segments": setup.segments} if setup.line_model == "distributed" else {}
    line = make_line(setup.line_model, setup.line_length_m, 0.004, **opts)
    return Plant(valve=VALVES[setup.valve], line_1=line, line_2=line, environment=setup.environment)


def default_gains(setup: Setup, plant: Plant) -> dict:
    """The gains of section 5.4.2 for the setup's lines (:func:`~sensor.pneumatic.controllers.smc_gains`,
    :func:`~sensor.pneumatic.controllers.line_model_gains`); PI and impedance keep their class
    defaults (chapter IV, 7.25 m)."""
    if setup.controller == "smc":
        return smc_gains(plant)
    if setup.controller == "line-model":
        return line_model_gains(plant)
    return {}


def controller_gains(setup: Setup, plant: Plant) -> dict:
    """:func:`default_gains` overridden by ``setup.gains``."""
    return {**default_gains(setup, plant), **dict(setup.gains)}


def make_controller(setup: Setup, model: ObserverModel, dt_s: float, plant: Plant | None = None):
    """The setup's controller: :func:`default_gains` overridden by ``setup.gains``."""
    ref = setup.ref
    obs = PressureObserver(model, setup.observer, model.gain_for_rate(setup.observer_rate_Hz), dt_s,
                           gain_on_s=setup.observer_on_s)
    gains = controller_gains(setup, build_plant(setup) if plant is None else plant)
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
        raise SensorInputError(f"controller {setup.controller!r} gains {sorted(gains)}: {exc}") from None


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
    ctrl = make_controller(setup, model, dt, plant)
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
                     "amplitude_N": setup.amplitude_N, "line_length_m": setup.line_length_m,
                     "gains": json.dumps({k: v for k, v in controller_gains(setup, plant).items()
                                         if isinstance(v, (int, float))})})
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
    if w.sizes["time"] < 2:
        raise SensorInputError(f"duration {float(ds.time[-1]):.4g} s: too short for the MSE window "
                          f"(a step at {reference.step_s:g} s needs a longer run)")
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


# --- the DACM sensor in the loop ------------------------------------------------------------------

class DacmForceSensor:
    """A DACM sensor model as the loop's force sensor: ``read(value, t)`` returns the calibrated
    newtons of one sample (hysteresis memory, optical noise, ADC); forces outside [0, range] are
    clipped and flagged by the model (``overload="saturate"``).  ``stiffness_N_m``: the secant
    stiffness range / input travel at full scale, put in series with the environment."""

    def __init__(self, source: str, seed: int = 0):
        from pathlib import Path

        from geometry.params import PRESETS, load_design, preset
        from sensor.readout.datasheet import datasheet
        from sensor.readout.sensor_model import build_sensor

        if source in PRESETS:
            design = preset(source)
        elif source.endswith(".toml"):
            design = load_design(Path(source))
        else:
            raise SensorInputError(f"sensor = {source!r}: must be a preset ({', '.join(PRESETS)}) or a .toml design file")
        self.model = build_sensor(design, overload="saturate")
        self.sheet = datasheet(self.model)
        self.name = self.model.name
        self.range_N = float(self.model.range_N)
        self.stiffness_N_m = self.range_N / self.model.input_travel_mm * 1e3
        self._stepper = self.model.stepper(np.random.default_rng(seed))

    def read(self, value: float, t: float) -> float:
        return self._stepper.step(value).newtons


def series_spring(environment_N_m: float, sensor_N_m: float) -> float:
    """Stiffness (N/m) of the environment spring and the sensor body in series."""
    return 1.0 / (1.0 / environment_N_m + 1.0 / sensor_N_m)


# --- the studies -----------------------------------------------------------------------------------

def _row(setup: Setup, **extra) -> dict:
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", CapacityWarning)
        ds = run(setup)
    out = {**extra, **metrics(ds, setup.ref), "gains": json.loads(ds.attrs["gains"]),
           "warnings": [str(w.message) for w in caught]}
    return out, ds


def observer_study(duration_s: float = 8.0, segments: int = 20) -> dict:
    """Chapter IV: estimation MSE (eq 44) of observer, standard model and valve pressures at 1 and
    2 Hz PI force tracking (24 N) and square-wave impedance control, 7.25 m lines, Festo valve
    (Figures 16-18); SMC impedance control with observer vs open-loop estimation at 0.5, 1 and
    1.5 Hz, Enfield valve (Figure 26); the switch-on transient of Figure 27."""
    tables: dict = {"estimation": [], "smc": [], "switch_on": {}}
    runs = {}
    for ctrl, ref in (("pi", "sine:1Hz"), ("pi", "sine:2Hz"), ("impedance", "square:0.5Hz")):
        for obs in OBSERVER_KINDS:
            s = Setup(controller=ctrl, observer=obs, reference=ref, duration_s=duration_s, segments=segments)
            row, ds = _row(s, experiment=f"{ctrl} {ref}", observer=obs)
            tables["estimation"].append(row)
            runs[(ctrl, ref, obs)] = ds
    for f in (0.5, 1.0, 1.5):
        for obs in ("force", "standard"):
            s = Setup(controller="smc", observer=obs, reference=f"sine:{f:g}Hz", duration_s=duration_s,
                      segments=segments, valve="enfield-lh05")
            s = replace(s, gains=(("impedance", _impedance_for(s)),))
            row, ds = _row(s, experiment=f"smc impedance z_d sine:{f:g}Hz", observer=obs)
            tables["smc"].append(row)
    s = Setup(controller="smc", observer="force", reference="sine:0.5Hz", duration_s=16.0, segments=segments,
              valve="enfield-lh05", observer_on_s=8.0)
    s = replace(s, gains=(("impedance", _impedance_for(s)),))
    ds = run(s)
    tables["switch_on"] = {"on_s": 8.0, **per_cycle(ds, 0.5)}
    runs["switch_on"] = ds
    return {"tables": tables, "runs": runs}


def _impedance_for(setup: Setup) -> Impedance:
    plant = build_plant(setup)
    model = ObserverModel.from_plant(plant)
    return Impedance(model, setup.ref, PressureObserver(model, "valve"), 1e-3)


def per_cycle(ds: xr.Dataset, frequency_Hz: float) -> dict:
    """Force MSE (N^2) and eq 44 pressure MSE (kPa^2) in each whole cycle (Figure 27)."""
    period = 1.0 / frequency_Hz
    n = int(float(ds.time[-1]) // period)
    force, pressure, start = [], [], []
    for i in range(n):
        w = ds.sel(time=slice(i * period, (i + 1) * period - 1e-9))
        e = w.desired_force_N - w.environment_force
        pt = [w[f"estimated_pressure_{s}_Pa"] - w.pressure_chamber.sel(side=s) for s in (1, 2)]
        force.append(float((e**2).mean()))
        pressure.append(float(0.5 * (pt[0] ** 2 + pt[1] ** 2).mean() / 1e6))
        start.append(i * period)
    return {"cycle_start_s": start, "force_mse_N2": force, "pressure_mse_kPa2": pressure}


CH5_LENGTHS_M = (2.0, 5.0, 7.25, 10.0)
CH5_REFERENCES = ("step", "sine:0.5Hz", "sine:1Hz", "sine:2Hz")
# Table 4 (line-model controller): length -> {reference: (MSE_1, MSE_2)} in N^2
TABLE4 = {2.0: {"sine:0.5Hz": (6.38, 4.33), "sine:1Hz": (9.28, 5.68), "sine:2Hz": (17.63, 8.16)},
          5.0: {"sine:0.5Hz": (1.23, 3.66), "sine:1Hz": (2.63, 5.89), "sine:2Hz": (6.44, 8.22)},
          7.25: {"sine:0.5Hz": (1.6, 4.0), "sine:1Hz": (3.36, 5.52), "sine:2Hz": (12.83, 7.97)},
          10.0: {"sine:0.5Hz": (2.44, 6.33), "sine:1Hz": (7.08, 8.85), "sine:2Hz": (22.85, 10.37)}}


def controller_study(duration_s: float = 6.0, amplitude_N: float = 24.0, segments: int = 20,
                     lengths=CH5_LENGTHS_M, references=CH5_REFERENCES, keep_runs=()) -> dict:
    """Chapter V: line-model controller vs standard SMC (standard-model pressures) on 2, 5, 7.25
    and 10 m lines with step, 0.5, 1 and 2 Hz references, Enfield valve; gains per length from
    the line (:func:`default_gains`, section 5.4.2), the same for every reference."""
    rows, runs = [], {}
    for length in lengths:
        for ref in references:
            for ctrl in ("smc", "line-model"):
                s = Setup(controller=ctrl, observer="standard", reference=ref, amplitude_N=amplitude_N,
                          line_length_m=length, duration_s=duration_s, valve="enfield-lh05", segments=segments)
                row, ds = _row(s, line_length_m=length, reference=ref, controller=ctrl)
                thesis = TABLE4.get(length, {}).get(ref)
                if ctrl == "line-model" and thesis:
                    row["thesis_mse1_N2"], row["thesis_mse2_N2"] = thesis
                rows.append(row)
                if (length, ref, ctrl) in keep_runs:
                    runs[(length, ref, ctrl)] = ds
    return {"rows": rows, "runs": runs}


SENSOR_PRESETS = ("basis-as-cut", "sample-a-as-cut", "sample-b-as-cut")


def sensor_study(duration_s: float = 8.0, environment_N_m: float = 2000.0, segments: int = 20,
                 presets=SENSOR_PRESETS, frequency_Hz: float = 1.0) -> dict:
    """The DACM sensor as the loop's force sensor (basis, samples A and B) against an ideal load
    cell on the same loop: PI force control of a 1 Hz sine between 15 % and 85 % of the sensor's
    range, observer on, 7.25 m lines, Festo valve, a push-only 2 kN/m spring in series with the
    sensor body.  Force MSE against the true contact force; pressure MSE of eq 44."""
    rows, runs = [], {}
    for name in presets:
        sensor = DacmForceSensor(name)
        k = series_spring(environment_N_m, sensor.stiffness_N_m)
        env = spring_contact(k, 0.025)
        amp, off = 0.35 * sensor.range_N, 0.5 * sensor.range_N
        for label, fs in (("DACM " + name, sensor), ("load cell (0.02 N noise)", None)):
            s = Setup(controller="pi", observer="force", reference=f"sine:{frequency_Hz:g}Hz", amplitude_N=amp,
                      offset_N=off, duration_s=duration_s, segments=segments, environment=env, force_sensor=fs)
            row, ds = _row(s, sensor=name, reading=label, range_N=sensor.range_N,
                           hysteresis_pct=sensor.sheet.hysteresis_pct, resolution_N=sensor.sheet.resolution_N,
                           stiffness_N_mm=sensor.stiffness_N_m / 1e3, loop_stiffness_N_mm=k / 1e3)
            w = ds.sel(time=window(ds, s.ref))
            row["reading_rms_error_N"] = float(((w.measured_force_N - w.environment_force) ** 2).mean() ** 0.5)
            rows.append(row)
            runs[(name, label)] = ds
    return {"rows": rows, "runs": runs}


# --- tables (markdown, next to the thesis) -----------------------------------------------------------

def _fmt(x: float) -> str:
    return "n/a" if x is None or (isinstance(x, float) and math.isnan(x)) else (f"{x:.3g}" if abs(x) < 1e4 else f"{x:.3e}")


def observer_tables(res: dict) -> str:
    t = res["tables"]
    lines = ["### Chapter IV: pressure estimation, 7.25 m lines (Figures 16-18, eq 44)", "",
             "| experiment | observer (kPa^2) | standard model (kPa^2) | valve ports (kPa^2) | force MSE (N^2) |",
             "|---|---|---|---|---|"]
    for exp in dict.fromkeys(r["experiment"] for r in t["estimation"]):
        by = {r["observer"]: r for r in t["estimation"] if r["experiment"] == exp}
        lines.append(f"| {exp} | {_fmt(by['force']['pressure_mse_kPa2'])} | {_fmt(by['standard']['pressure_mse_kPa2'])} | "
                     f"{_fmt(by['valve']['pressure_mse_kPa2'])} | {_fmt(by['force']['force_mse_N2'])} |")
    lines += ["", "Thesis (Figures 16-18, plotted only): the observer's error is far below the standard model's and "
              "the valve pressures', which are comparable to each other and worse at 2 Hz.", "",
              "### Chapter IV: SMC impedance control, observer vs open-loop estimation (Figure 26)", "",
              "| z_d | force MSE, observer (N^2) | force MSE, open loop (N^2) | change | pressure MSE, observer | "
              "pressure MSE, open loop (kPa^2) |", "|---|---|---|---|---|---|"]
    for exp in dict.fromkeys(r["experiment"] for r in t["smc"]):
        by = {r["observer"]: r for r in t["smc"] if r["experiment"] == exp}
        f, s = by["force"], by["standard"]
        ch = 100 * (f["force_mse_N2"] / s["force_mse_N2"] - 1) if s["force_mse_N2"] > 0 else math.nan
        lines.append(f"| {exp.split()[-1]} | {_fmt(f['force_mse_N2'])} | {_fmt(s['force_mse_N2'])} | {ch:+.0f} % | "
                     f"{_fmt(f['pressure_mse_kPa2'])} | {_fmt(s['pressure_mse_kPa2'])} |")
    sw = t["switch_on"]
    before = [m for c, m in zip(sw["cycle_start_s"], sw["pressure_mse_kPa2"]) if c + 2 <= sw["on_s"]]
    after = [m for c, m in zip(sw["cycle_start_s"], sw["pressure_mse_kPa2"]) if c >= sw["on_s"] + 2]
    fb = [m for c, m in zip(sw["cycle_start_s"], sw["force_mse_N2"]) if c + 2 <= sw["on_s"]]
    fa = [m for c, m in zip(sw["cycle_start_s"], sw["force_mse_N2"]) if c >= sw["on_s"] + 2]
    lines += ["", "Thesis (Figure 26, section 4.3.4): the observer lowers both errors; the force gain grows with "
              "frequency, about 25 % at 1.5 Hz.", "",
              f"Switch-on (Figure 27, 0.5 Hz, observer on at {sw['on_s']:g} s): pressure MSE per cycle "
              f"{_fmt(float(np.mean(before)))} -> {_fmt(float(np.mean(after)))} kPa^2, force MSE "
              f"{_fmt(float(np.mean(fb)))} -> {_fmt(float(np.mean(fa)))} N^2 (means over the cycles before / after)."]
    return "\n".join(lines) + "\n"


def controller_tables(res: dict) -> str:
    rows = res["rows"]
    refs = list(dict.fromkeys(r["reference"] for r in rows))
    lines = ["### Chapter V: line-model controller vs standard SMC (Table 4, Figure 32)", "",
             "MSE_1 (force, N^2) of SMC | line-model (this simulation); Table 4's line-model MSE_1 / MSE_2 in "
             "brackets; MSE_2 = virtual-input tracking of the line-model controller.", "",
             "| length | " + " | ".join(refs) + " |", "|---" * (len(refs) + 1) + "|"]
    for length in dict.fromkeys(r["line_length_m"] for r in rows):
        cells = []
        for ref in refs:
            by = {r["controller"]: r for r in rows if r["line_length_m"] == length and r["reference"] == ref}
            lm = by["line-model"]
            th = TABLE4.get(length, {}).get(ref)
            cell = f"{_fmt(by['smc']['force_mse_N2'])} \\| {_fmt(lm['force_mse_N2'])} (MSE_2 {_fmt(lm['virtual_input_mse_N2'])})"
            if th:
                cell += f" [{th[0]:g} / {th[1]:g}]"
            cells.append(cell)
        lines.append(f"| {length:g} m | " + " | ".join(cells) + " |")
    lines += ["", "Gains per length (section 5.4.2, from the line's dynamics: smc_gains, line_model_gains):", "",
              "| length | SMC eta (N/s) / phi (N) / lambda (1/s) | line model k_p1 / lambda (1/s) / k_m (1/s) / k_p2 (1/s) |",
              "|---|---|---|"]
    for length in dict.fromkeys(r["line_length_m"] for r in rows):
        g = {r["controller"]: r["gains"] for r in rows if r["line_length_m"] == length}
        s, m = g["smc"], g["line-model"]
        lines.append(f"| {length:g} m | {s['eta_N_s']:.4g} / {s['phi_N']:.3g} / {s['lam_per_s']:.3g} | {m['kp1']:.3g} / "
                     f"{m['lam_per_s']:.3g} / {m['flow_rate_per_s']:.4g} / {m['kp2_per_s']:.3g} |")
    lines += ["", "### Chapter V: chamber-pressure estimation from the valve pressures (Figure 37)", "",
              "| length | reference | standard model (kPa^2) | two-volume line model (kPa^2) |", "|---|---|---|---|"]
    for r in rows:
        if r["controller"] == "line-model":
            lines.append(f"| {r['line_length_m']:g} m | {r['reference']} | {_fmt(r['pressure_mse_kPa2'])} | "
                         f"{_fmt(r['line_model_pressure_mse_kPa2'])} |")
    return "\n".join(lines) + "\n"


def sensor_tables(res: dict) -> str:
    lines = ["### The DACM sensor in the loop (PI force control, observer on, 7.25 m, 1 Hz)", "",
             "| sensor | range (N) | hysteresis (% FS) | resolution (N) | stiffness (N/mm) | loop spring (N/mm) | "
             "reading | reading RMS error (N) | force MSE (N^2) | pressure MSE (kPa^2) |", "|---" * 10 + "|"]
    for r in res["rows"]:
        lines.append(f"| {r['sensor']} | {r['range_N']:.3g} | {r['hysteresis_pct']:.3g} | {r['resolution_N']:.2g} | "
                     f"{r['stiffness_N_mm']:.3g} | {r['loop_stiffness_N_mm']:.3g} | {r['reading']} | "
                     f"{r['reading_rms_error_N']:.3g} | {_fmt(r['force_mse_N2'])} | {_fmt(r['pressure_mse_kPa2'])} |")
    return "\n".join(lines) + "\n"
