"""Fixed-rate controller loop around the plant; results as a labelled xarray dataset.

A controller is any callable ``controller(t, measurements) -> u`` returning the valve
command u in [-1, 1] (clipped), called at ``rate_Hz`` (default 1 kHz) with a dict of sensor
readings (keys in :data:`MEASUREMENT_KEYS`, SI units).  The command is held between samples
while the compiled stepper integrates the plant (see :mod:`._kernel`).  Plain
NoisyQuantised and Encoder sensors and the differentiating filters are read inside the compiled
control period (the noise of the whole run drawn from each sensor's own stream in one batch:
the same readings as their ``read`` methods); any other sensor object is read in Python.
"""
from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np
import xarray as xr

from sensor.errors import SensorInputError, SolverError
from sensor.pneumatic import _kernel as K
from sensor.pneumatic.cylinder import FixedChambers
from sensor.pneumatic.plant import CompiledPlant, Plant
from sensor.pneumatic.sensors import (
    DifferentiatingFilter,
    Encoder,
    NoisyQuantised,
    Sensors,
)

MEASUREMENT_KEYS = ("position_m", "velocity_m_s", "acceleration_m_s2", "force_N",
                    "pressure_valve_1_Pa", "pressure_valve_2_Pa",
                    "pressure_chamber_1_Pa", "pressure_chamber_2_Pa")
MAX_VELOCITY_M_S = 100.0
PROGRESS_PERIODS = 1000
MAX_STORED_VALUES = 2e8   # time samples x (states + readings): 1.6 GB of float64 at most


def constant_command(u: float) -> Callable[[float, dict], float]:
    """Open-loop controller holding command u."""
    return lambda t, m: u


def simulate(plant: Plant | CompiledPlant, controller: Callable[[float, dict], float], duration_s: float,
             rate_Hz: float = 1000.0, sensors: Sensors | None = None, initial_state: np.ndarray | None = None,
             substep_s: float | None = None, progress: Callable[[int, int], None] | None = None) -> xr.Dataset:
    """Run the loop for ``duration_s`` and return every state, command and reading over time.

    progress: called as ``progress(done, total)`` (control periods) every PROGRESS_PERIODS and at the end."""
    cp = plant if isinstance(plant, CompiledPlant) else plant.compile()
    if not (math.isfinite(duration_s) and duration_s > 0):
        raise SensorInputError(f"duration_s = {duration_s!r}: must be a positive finite number")
    if not (math.isfinite(rate_Hz) and rate_Hz > 0):
        raise SensorInputError(f"rate_Hz = {rate_Hz!r}: must be a positive finite number")
    dt = 1.0 / rate_Hz
    nsub, h = cp.substeps(dt, substep_s)
    sensors = Sensors() if sensors is None else sensors
    x = cp.initial_state() if initial_state is None else np.array(initial_state, float)
    if x.shape != (cp.n_states,):
        raise SensorInputError(f"initial_state has shape {x.shape}: must be ({cp.n_states},)")
    bad = K.first_bad(x, cp.ps, MAX_VELOCITY_M_S)
    if bad >= 0:
        raise SensorInputError(f"simulation stopped at t = 0 s: state {cp.labels[bad]} = {float(x[bad])!r} "
                          "is not finite or outside its physical range")
    nsteps = run_steps(duration_s, rate_Hz, cp.n_states)
    delays = np.round(cp.delay_s / h).astype(int)
    ps = cp.ps.copy()
    ps["delay"] = delays
    pc = cp.pc.copy()
    if pc[0]["spool_order"] > 0:
        pc[0]["spool_step"] = np.reshape(cp.plant.valve.spool_step_matrices(h), (2, 2))
    ring = np.zeros((2, int(delays.max()) + 1))
    acc = K.record(K.ACC)
    work = K.work_array(cp.pv, cp.kn)
    states = np.empty((nsteps + 1, cp.n_states))
    log = K.record(K.LOG, nsteps + 1)   # flows, Mach, choking, force, command, readings per period
    for name in K.LOG.names:
        log[name] = np.nan
    p_valve = (int(cp.ps[0]["o_p"]), int(cp.ps[1]["o_p"]))
    p_ch = (p_valve[0] + cp.node_count(0) - 1, p_valve[1] + cp.node_count(1) - 1)
    p_read = np.array(p_valve + p_ch, np.int64)
    loop = K.pack_loop(nsub, h, dt, MAX_VELOCITY_M_S, pc, ps, cp.kn, cp.km, cp.ka, p_read)
    table = np.vstack([cp.grid, cp.csup, cp.cexh])
    force = K.piston_forces(x[0], x[1], x[p_ch[0]], x[p_ch[1]], cp.pc[0])[3]
    acc[0]["force"] = force
    states[0], log[0]["force"] = x, force
    raw = tuple(float(v) for v in (x[0], force, *x[p_read]))
    compiled = _compiled_sensors(sensors, nsteps + 1, dt)
    if compiled is None:
        sens, filt, noise = K.record(K.SENSOR, 6), K.record(K.FILTER, 2), np.zeros((1, 6))
        sens["kind"] = -1.0
        vel_f = DifferentiatingFilter(sensors.differentiation_cutoff_Hz, dt)
        acc_f = DifferentiatingFilter(sensors.differentiation_cutoff_Hz, dt)
        read_pos, read_f = sensors.position.read, sensors.force.read
        read_v1, read_v2 = sensors.pressure_valve_1.read, sensors.pressure_valve_2.read
        read_c1, read_c2 = sensors.pressure_chamber_1.read, sensors.pressure_chamber_2.read
    else:
        sens, filt, noise, noisy = compiled
        K.read_sensors(0, *raw, K.as_bytes(sens), K.as_bytes(filt), noise, K.as_bytes(log))
        m = tuple(float(v) for v in log[0]["meas"])
    meas = log["meas"]
    kz, kv, ka, kf, kv1, kv2, kc1, kc2 = MEASUREMENT_KEYS
    period = K.control_period
    loop_b, acc_b, log_b, sens_b, filt_b = (K.as_bytes(a) for a in (loop, acc, log, sens, filt))
    k = 0
    try:
        for k in range(nsteps + 1):
            t = k * dt
            if compiled is None:
                z = read_pos(raw[0], t)
                vz = vel_f.update(z)
                m = (z, vz, acc_f.update(vz), read_f(raw[1], t), read_v1(raw[2], t), read_v2(raw[3], t),
                     read_c1(raw[4], t), read_c2(raw[5], t))
                meas[k] = m
            if progress is not None and (k % PROGRESS_PERIODS == 0 or k == nsteps):
                progress(k, nsteps)
            if k == nsteps:
                break
            u = float(controller(t, {kz: m[0], kv: m[1], ka: m[2], kf: m[3], kv1: m[4], kv2: m[5], kc1: m[6],
                                     kc2: m[7]}))
            if not math.isfinite(u):
                raise SensorInputError(f"controller returned command {u!r} at t = {t:.6g} s: must be finite")
            out = period(k, u, x, loop_b, cp.pv, table, ring, acc_b, work, states, log_b, sens_b, filt_b, noise)
            if out[0] >= 0 or out[1] >= 0:
                _stop(cp, x, log, ps, k, t + dt, out[0], out[1], acc, substep_s is not None)
            if compiled is None:
                raw = out[2:8]
            else:
                m = out[2:]
    finally:
        if compiled is not None:   # the sensors' noise streams advance by the reads made
            for sensor in noisy:
                sensor.consume(k + 1)
    return _dataset(cp, states, log, dt, nsub, h, p_valve, p_ch)


SENSOR_NAMES = ("position", "force", "pressure_valve_1", "pressure_valve_2", "pressure_chamber_1",
                "pressure_chamber_2")


def _compiled_sensors(sensors: Sensors, reads: int, dt: float):
    """(sens, filt, noise, noisy sensors) for :func:`K.read_sensors` when all six sensors are plain
    NoisyQuantised or Encoder objects (their exact arithmetic, and the noise each would draw in
    ``reads`` reads, drawn from its own stream in one batch), else None (Python reads). One
    object in two slots is read in Python: its reads take alternate draws of its one stream."""
    objs = [getattr(sensors, name) for name in SENSOR_NAMES]
    if not all(type(o) in (NoisyQuantised, Encoder) for o in objs) or len({id(o) for o in objs}) < len(objs):
        return None
    sens, filt = K.record(K.SENSOR, 6), K.record(K.FILTER, 2)
    noise = np.zeros((reads, 6))
    noisy = []
    for i, o in enumerate(objs):
        if type(o) is Encoder:
            sens[i] = (K.SENSOR_ENCODER, 0.0, o.count_m)
            continue
        sens[i] = (K.SENSOR_NOISY, o.noise, o.resolution)
        if o.noise > 0:
            noise[:, i] = o.upcoming(reads)
            noisy.append(o)
    for i in (0, 1):
        filt[i]["a"], filt[i]["b"] = DifferentiatingFilter(sensors.differentiation_cutoff_Hz, dt).coefficients
    return sens, filt, noise, noisy


def _stop(cp, x, log, ps, k, t, bad, over, acc, given: bool) -> None:
    """Raise the error of a run stopped at control period k (time t at its end); ``given``: the
    substep was the caller's (then it may be the cause), not the automatic one."""
    if over >= 0:
        raise SolverError(f"simulation stopped at t = {t:.6g} s: the side {over + 1} line reached Mach "
                          f"{log[k]['mach'][over]:.3g} in flow element {int(acc[0]['element'][over])} of "
                          f"{cp.node_count(over) - 1}, beyond the distributed line's range (subsonic flow up to "
                          f"Mach {ps[over]['mach_limit']:g}; its isothermal ends choke at Mach "
                          f"{1 / math.sqrt(cp.plant.air.gamma):.3f}); cure: "
                          + ("a smaller substep_s, or the automatic one (substep_s=None)" if given else
                             "a lower supply pressure, a smaller valve or a larger bore (the flow would be "
                             "supersonic)"))
    raise SensorInputError(f"simulation stopped at t = {t:.6g} s: state {cp.labels[bad]} = "
                           f"{float(x[bad])!r} is not finite or outside its physical range")


def run_steps(duration_s: float, rate_Hz: float, n_states: int) -> int:
    """Control periods of a run, checked before anything is allocated: at least one, and the
    stored samples (duration x rate x states) within MAX_STORED_VALUES."""
    steps = duration_s * rate_Hz
    if not steps >= 0.5:
        raise SensorInputError(f"duration {duration_s!r} s at {rate_Hz:g} Hz: must cover at least one control "
                               f"period ({1.0 / rate_Hz:.3g} s)")
    values = (steps + 1.0) * (n_states + len(MEASUREMENT_KEYS) + 12)
    if not values <= MAX_STORED_VALUES:
        raise SensorInputError(f"duration {duration_s:.4g} s x rate {rate_Hz:g} Hz x {n_states} states stores "
                               f"{values:.3g} values: must be <= {MAX_STORED_VALUES:.3g} (shorten the duration, "
                               "lower the rate or use fewer segments)")
    return round(steps)


def _dataset(cp, states, log, dt, nsub, h, p_valve, p_ch):
    valve_flow, chamber_flow, mach, exit_mach, choked = (log[name] for name in (
        "valve", "chamber", "mach", "exit_mach", "choked"))
    force, commands = log["force"], log["command"]
    time = np.arange(states.shape[0]) * dt
    side = [1, 2]
    ds = xr.Dataset(
        {
            "states": (("time", "state"), states),
            "piston_position": ("time", states[:, 0], {"units": "m"}),
            "piston_velocity": ("time", states[:, 1], {"units": "m/s"}),
            "pressure_valve": (("time", "side"), states[:, list(p_valve)], {"units": "Pa"}),
            "pressure_chamber": (("time", "side"), states[:, list(p_ch)], {"units": "Pa"}),
            "valve_mass_flow": (("time", "side"), valve_flow,
                                {"units": "kg/s", "note": "mean over the control period starting at time"}),
            "chamber_mass_flow": (("time", "side"), chamber_flow,
                                  {"units": "kg/s", "note": "line into chamber, mean over the period"}),
            "line_max_mach": (("time", "side"), mach,
                              {"units": "1", "note": "largest mean Mach number of the line's flow elements "
                                                     "over the period (0 without flow elements)"}),
            "line_exit_mach": (("time", "side"), exit_mach,
                               {"units": "1", "note": "largest Mach number of a tube end face the flow leaves "
                                                      "by, over the period (at most 1/sqrt(gamma), isothermal)"}),
            "line_choked": (("time", "side"), choked > 0.5,
                            {"note": "an end face of the line was choked during the period (exit jet at the "
                                     "isothermal sonic speed, or an entrance the node cannot feed)"}),
            "chamber_temperature": (("time", "side"), _temperatures(cp, states), {"units": "K"}),
            "spool_position": ("time", states[:, int(cp.pc[0]["ox"]) + K.X_SPOOL],
                               {"units": "1", "note": "the command itself for an ideal spool"}),
            "environment_force": ("time", force, {"units": "N"}),
            "command": ("time", commands, {"units": "1", "note": "valve command held over the period"}),
            **{f"measured_{key}": ("time", log["meas"][:, j]) for j, key in enumerate(MEASUREMENT_KEYS)},
        },
        coords={"time": ("time", time, {"units": "s"}), "side": side, "state": cp.labels},
        attrs={"rate_Hz": 1.0 / dt, "substeps": nsub, "substep_s": h,
               "line_1": repr(cp.plant.line_1), "line_2": repr(cp.plant.line_2),
               "valve": cp.plant.valve.name, "supply_Pa": cp.plant.supply_Pa},
    )
    return ds


def _temperatures(cp, states) -> np.ndarray:
    """Chamber-node gas temperatures T = P V / (m R) (K) of every row of ``states``."""
    ox = int(cp.pc[0]["ox"])
    act = cp.plant.actuator
    v1, v2 = ((act.volume_1_m3, act.volume_2_m3) if isinstance(act, FixedChambers)
              else act.volumes(states[:, 0]))
    r_gas = cp.plant.air.gas_constant_J_kgK
    out = np.empty((states.shape[0], 2))
    for s, v in enumerate((v1, v2)):
        p = states[:, int(cp.ps[s]["o_p"]) + cp.node_count(s) - 1]
        out[:, s] = p * (v + cp.pv[s, cp.node_count(s) - 1]) / (states[:, ox + s] * r_gas)
    return out
