"""One closed-loop experiment of chapters IV and V on the high-fidelity plant: its setup, its
plant and controller, and its run.

:func:`run` builds one experiment (plant, sensors, observer, controller), simulates it with the
fixed-rate harness and returns the harness' dataset with the controller's log added
(estimated pressures, desired force, virtual input, ...); :mod:`.loop_metrics` measures it.

One physical start: plant (chambers and every line node at the atmosphere, piston at
mid-stroke, spring relaxed: zero force, an equilibrium of eq 17-18), observer and line-model
estimators all start from the atmosphere.

Rig: a 16 mm Airpel-like cylinder (plant default) on an attached 5 kN/m spring (the thesis'
"spring system ... proportional to the piston displacement"), both lines distributed (20
segments, frequency-dependent friction and heat transfer), 6 bar abs supply, default noisy
sensors (load cell, potentiometer, P51-class pressure transducers), 1 kHz loop.  The Festo
valve for section 4.2, the Enfield LH05 for section 4.3 and chapter V, as the thesis.  Plant
parameters are never adjusted to reach a thesis number; the measured friction of section 4.3
(0.25 N stiction), spool dynamics and the chamber energy equation are :class:`Setup` fields.
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
    LINE_MODEL_VARIANTS,
    Impedance,
    LineModel,
    PIForce,
    Reference,
    SlidingMode,
    line_model_gains,
    parse_reference,
    smc_gains,
)
from sensor.pneumatic.cylinder import Cylinder, Environment, mass_spring_damper
from sensor.pneumatic.lines import make_line
from sensor.pneumatic.loop_metrics import metrics
from sensor.pneumatic.observer import OBSERVER_KINDS, ObserverModel, PressureObserver
from sensor.pneumatic.plant import Plant
from sensor.pneumatic.sensors import Sensors, ideal_sensors
from sensor.pneumatic.simulate import simulate
from sensor.pneumatic.valve import VALVES

OBSERVER_RATE_HZ = 10.0  # correction pole at mid-stroke (k of eq 22 from it)
STUDY_DURATION_S = 30.0  # shortest study run; long enough to settle by the rule of .loop_metrics ...
SETTLE_PERIODS = 25      # ... and at least this many periods: the SMC's observer error needs ~20 s
                         # at 1 Hz and ~40 s at 0.5 Hz to reach its steady size (measured)
STEP_AT_S = 3.0          # a step reference jumps here, after the start has settled
#: Plant substep of an experiment (s; :class:`Setup`: `dacm loop`, its studies and the
#: examples): finer than simulate's automatic 0.25 ms for distributed lines, because the
#: studies' verdicts sit near numeric criteria and a single run should print their numbers.
#: Against 20 us runs the chapter V rows at 0.1 ms keep MSE_2 within 3 % (2 m, 1 Hz: 1.19 vs
#: 1.23 N^2; at 0.14 ms, the automatic step on 2 m lines, 1.32, enough to move the MSE_2
#: spread across Table 4's 1.73).
LOOP_SUBSTEP_S = 1.0e-4
#: Thesis section 4.3: "the stiction of the piston-cylinder was identified to be 0.25 N".
THESIS_STICTION_N = 0.25
#: Chamber wall conductance h A (W/K) of the energy equation: h = 30 W/(m^2 K) (free convection
#: and conduction into the aluminium barrel) over the ~1.7e-3 m^2 of a 16 mm chamber at mid-stroke.
ENERGY_WALL_W_K = 0.05
#: Spool bandwidth (Hz, first order) of the plant-physics study: the thesis neglects spool dynamics
#: as "significantly higher than the bandwidth of operation" and gives no figure; 100 Hz is the
#: class of small proportional spool valves (Festo MPYE, Enfield LS-V) - an assumption, stated.
STUDY_SPOOL_BANDWIDTH_HZ = 100.0
MAX_FRICTION_N = 100.0   # far above the actuator's friction; a bound on a typed value


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
    duration_s: float = STUDY_DURATION_S
    step_s: float = STEP_AT_S
    observer_rate_Hz: float = OBSERVER_RATE_HZ
    observer_on_s: float = 0.0
    environment: Environment = field(default_factory=lambda: mass_spring_damper(0.0, 5000.0, 20.0, 0.025))
    gains: tuple = ()
    force_sensor: object = None
    seed: int = 0
    substep_s: float | None = LOOP_SUBSTEP_S   # plant substep (s); None: the plant's automatic choice
    stiction_N: float = 0.0          # static friction F_s (N), Stribeck stick-slip when > 0 (eq 18)
    coulomb_N: float = Cylinder.coulomb_N   # sliding (Coulomb) friction F_c (N)
    spool_bandwidth_Hz: float = math.inf    # first-order spool; inf: ideal spool (the thesis)
    energy: bool = False             # chamber energy equation (wall h A = ENERGY_WALL_W_K) instead of eq 15
    sensor_noise: bool = True        # False: ideal default sensors (the noise-free twin of loop_metrics.classify)

    def __post_init__(self) -> None:
        if self.controller not in CONTROLLERS:
            raise SensorInputError(f"controller = {self.controller!r}: must be one of {', '.join(CONTROLLERS)}")
        if self.observer not in OBSERVER_KINDS:
            raise SensorInputError(f"observer = {self.observer!r}: must be one of {', '.join(OBSERVER_KINDS)}")
        if self.valve not in VALVES:
            raise SensorInputError(f"valve = {self.valve!r}: must be one of {', '.join(VALVES)}")
        if not (math.isfinite(self.duration_s) and self.duration_s > 0):
            raise SensorInputError(f"duration = {self.duration_s!r} s: must be a positive finite number")
        if self.substep_s is not None and not (math.isfinite(self.substep_s) and self.substep_s > 0):
            raise SensorInputError(f"substep_s = {self.substep_s!r}: must be a positive finite number of seconds")
        for name in ("stiction_N", "coulomb_N"):
            value = getattr(self, name)
            if not (math.isfinite(value) and 0 <= value <= MAX_FRICTION_N):
                raise SensorInputError(f"{name} = {value!r}: must be a finite force in [0, {MAX_FRICTION_N:g}] N")
        if 0 < self.stiction_N < self.coulomb_N:
            raise SensorInputError(f"stiction_N = {self.stiction_N!r}: must be 0 (no stick-slip) or >= coulomb_N = "
                                   f"{self.coulomb_N!r} (static friction is at least the sliding friction)")
        if not (self.spool_bandwidth_Hz > 0 and not math.isnan(self.spool_bandwidth_Hz)):
            raise SensorInputError(f"spool_bandwidth_Hz = {self.spool_bandwidth_Hz!r}: must be > 0 (inf: ideal spool)")

    @property
    def ref(self) -> Reference:
        return parse_reference(self.reference, self.amplitude_N, self.offset_N, self.step_s)


def settling_duration_s(reference: str) -> float:
    """Default run length (s) for a reference: STUDY_DURATION_S, or SETTLE_PERIODS periods of a
    slower periodic reference (0.5 Hz: 50 s)."""
    ref = parse_reference(reference)
    return STUDY_DURATION_S if ref.kind == "step" else max(STUDY_DURATION_S, SETTLE_PERIODS / ref.frequency_Hz)


def build_plant(setup: Setup) -> Plant:
    opts = {"segments": setup.segments} if setup.line_model == "distributed" else {}
    line = make_line(setup.line_model, setup.line_length_m, 0.004, **opts)
    actuator = Cylinder(coulomb_N=setup.coulomb_N, stiction_N=setup.stiction_N,
                        wall_conductance_W_K=ENERGY_WALL_W_K if setup.energy else None)
    valve = replace(VALVES[setup.valve], bandwidth_Hz=setup.spool_bandwidth_Hz)
    return Plant(valve=valve, line_1=line, line_2=line, actuator=actuator, environment=setup.environment)


def default_gains(setup: Setup, plant: Plant) -> dict:
    """The gains of section 5.4.2 for the setup's lines (:func:`~sensor.pneumatic.controllers.smc_gains`,
    :func:`~sensor.pneumatic.controllers.line_model_gains`); PI and impedance keep their class
    defaults (chapter IV, 7.25 m)."""
    if setup.controller == "smc":
        return smc_gains(plant)
    if setup.controller in LINE_MODEL_VARIANTS:
        return line_model_gains(plant, LINE_MODEL_VARIANTS[setup.controller])
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
                    f"[{lo:.4g}, {hi:.4g}] N (supply {model.params['p_supply'] / 1e5:.3g} bar abs, eq 17)")
    rng = getattr(setup.force_sensor, "range_N", None)
    if rng is not None and (rlo < 0 or rhi > rng):
        msgs.append(f"reference spans [{rlo:.4g}, {rhi:.4g}] N: beyond the force sensor's range [0, {rng:.4g}] N")
    for msg in msgs:
        warnings.warn(msg, CapacityWarning, stacklevel=2)
    return msgs


def run(setup: Setup, rate_Hz: float = 1000.0, progress=None) -> xr.Dataset:
    """Simulate one experiment; the dataset carries the harness' variables plus the controller's
    log (``desired_force_N``, ``estimated_pressure_1_Pa``, ...) and the setup in ``attrs``.
    ``progress(done, total)`` counts control periods (see :func:`~sensor.pneumatic.simulate.simulate`)."""
    plant = build_plant(setup)
    model = ObserverModel.from_plant(plant)
    dt = 1.0 / rate_Hz
    ctrl = make_controller(setup, model, dt, plant)
    check_capacity(setup, model)
    sensors = Sensors() if setup.sensor_noise else ideal_sensors()
    if setup.force_sensor is not None:
        sensors = replace(sensors, force=setup.force_sensor)
    ds = simulate(plant, ctrl, setup.duration_s, rate_Hz, sensors, substep_s=setup.substep_s, progress=progress)
    rows = np.full((ds.sizes["time"], len(ctrl.channels)), np.nan)
    rows[:len(ctrl.rows)] = np.asarray(ctrl.rows, float)
    for j, name in enumerate(ctrl.channels):
        ds[name] = ("time", rows[:, j])
    z = ds.piston_position.values
    stroke = model.params["stroke"]
    if np.any(z < 0) or np.any(z > stroke):
        warnings.warn(f"the piston reached an end stop (z from {z.min() * 1e3:.3g} to {z.max() * 1e3:.3g} mm, "
                      f"stroke {stroke * 1e3:.3g} mm): eq 18 then misses the stop force", CapacityWarning,
                      stacklevel=2)
    ds.attrs.update({"controller": setup.controller, "observer": setup.observer, "reference": setup.reference,
                     "amplitude_N": setup.amplitude_N, "line_length_m": setup.line_length_m,
                     "gains": json.dumps({k: v for k, v in controller_gains(setup, plant).items()
                                         if isinstance(v, (int, float))})})
    return ds



def measure(setup: Setup, ds: xr.Dataset) -> dict:
    """:func:`~sensor.pneumatic.loop_metrics.metrics` of a run of ``setup``; when the run is
    neither settled nor a limit cycle, its noise-free twin (``sensor_noise`` off) is run and
    consulted (:func:`~sensor.pneumatic.loop_metrics.classify`)."""
    m = metrics(ds, setup.ref)
    if m["status"] == "unsettled" and setup.sensor_noise:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", CapacityWarning)   # the run itself has warned already
            m = metrics(ds, setup.ref, twin=run(replace(setup, sensor_noise=False)))
    return m


def physics_from_flags(stiction: float, coulomb: float | None, spool_bandwidth: float, energy: bool) -> dict:
    """The Setup fields of ``dacm loop``'s --stiction, --coulomb (None: the cylinder's default),
    --spool-bandwidth and --energy, checked with the flags' names in the messages."""
    coulomb = Cylinder.coulomb_N if coulomb is None else coulomb
    for flag, value in (("--stiction", stiction), ("--coulomb", coulomb)):
        if not (math.isfinite(value) and 0 <= value <= MAX_FRICTION_N):
            raise SensorInputError(f"{flag} {value!r}: must be a finite force in [0, {MAX_FRICTION_N:g}] N")
    if 0 < stiction < coulomb:
        raise SensorInputError(f"--stiction {stiction!r}: must be 0 (no stick-slip) or >= the Coulomb friction "
                               f"{coulomb:g} N")
    if not (spool_bandwidth > 0 and not math.isnan(spool_bandwidth)):
        raise SensorInputError(f"--spool-bandwidth {spool_bandwidth!r}: must be a positive number of Hz")
    return {"stiction_N": stiction, "coulomb_N": coulomb, "spool_bandwidth_Hz": spool_bandwidth, "energy": bool(energy)}


def setup_from_flags(controller: str, observer: str, reference: str, amplitude: float | None, offset: float | None,
                     line_length: float, segments: int, valve: str | None, sensor: str | None,
                     duration: float | None, physics: dict) -> tuple[Setup, list[str]]:
    """``dacm loop``'s single-run Setup from its flags (checked with the flags' names; ``physics``
    from :func:`physics_from_flags`) and the notes to print: the valve defaults to the thesis'
    (Festo for PI/impedance, Enfield otherwise); a DACM ``sensor`` puts a push-only 2 kN/m spring
    in series with it and a reference within its range."""
    from sensor.pneumatic.controllers import MAX_REFERENCE_N
    from sensor.pneumatic.cylinder import spring_contact
    from sensor.pneumatic.dacm_sensor import DacmForceSensor, sensor_reference, series_spring
    from sensor.pneumatic.lines import MAX_LENGTH_M

    if controller not in CONTROLLERS:
        raise SensorInputError(f"--controller {controller!r}: must be one of {', '.join(CONTROLLERS)}")
    if observer not in OBSERVER_KINDS:
        raise SensorInputError(f"--observer {observer!r}: must be one of {', '.join(OBSERVER_KINDS)}")
    if not (math.isfinite(line_length) and 0 < line_length <= MAX_LENGTH_M):
        raise SensorInputError(f"--line-length {line_length!r}: must be a positive finite number <= "
                               f"{MAX_LENGTH_M:g} (m)")
    for flag, value in (("--amplitude", amplitude), ("--offset", offset)):
        if value is not None and not (math.isfinite(value) and abs(value) <= MAX_REFERENCE_N):
            raise SensorInputError(f"{flag} {value!r}: must be a finite force within +-{MAX_REFERENCE_N:g} N")
    valve = valve or ("festo-mpye-5-1/8-lf" if controller in ("pi", "impedance") else "enfield-lh05")
    kw, notes, amp, off = {}, [], 24.0, 0.0
    if sensor:
        fs = DacmForceSensor(sensor)
        kw = {"force_sensor": fs, "environment": spring_contact(series_spring(2000.0, fs.stiffness_N_m), 0.025)}
        amp, off = sensor_reference(fs.range_N)
        if amplitude is None or offset is None:
            notes.append(f"note: reference within the sensor's {fs.range_N:.3g} N range: amplitude "
                         f"{amplitude if amplitude is not None else amp:.3g} N, offset "
                         f"{offset if offset is not None else off:.3g} N (set --amplitude/--offset to change)")
    setup = Setup(controller=controller, observer=observer, reference=reference,
                  amplitude_N=amp if amplitude is None else amplitude, offset_N=off if offset is None else offset,
                  line_length_m=line_length, segments=segments, valve=valve,
                  duration_s=settling_duration_s(reference) if duration is None else duration, **physics, **kw)
    return setup, notes
