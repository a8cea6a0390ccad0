"""Fixed-rate controller loop around the plant; results as a labelled xarray dataset.

A controller is any callable ``controller(t, measurements) -> u`` returning the valve
command u in [-1, 1] (clipped), called at ``rate_Hz`` (default 1 kHz) with a dict of sensor
readings (keys in :data:`MEASUREMENT_KEYS`, SI units).  The command is held between samples
while the compiled stepper integrates the plant (see :mod:`._kernel`).
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
from sensor.pneumatic.sensors import DifferentiatingFilter, Sensors

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
    bad = K.first_bad(x, cp.off, cp.ps, MAX_VELOCITY_M_S)
    if bad >= 0:
        raise SensorInputError(f"simulation stopped at t = 0 s: state {cp.labels[bad]} = {float(x[bad])!r} "
                          "is not finite or outside its physical range")
    nsteps = run_steps(duration_s, rate_Hz, cp.n_states)
    delays = np.round(cp.delay_s / h).astype(int)
    ps = cp.ps.copy()
    ps[:, K.S_DELAY] = delays
    pc = cp.pc.copy()
    if pc[K.SPOOL_ORDER] > 0:
        pc[[K.SP_A00, K.SP_A01, K.SP_A10, K.SP_A11]] = cp.plant.valve.spool_step_matrices(h)
    ring = np.zeros((2, int(delays.max()) + 1))
    head = 0
    acc = np.zeros(K.N_ACC)
    work = K.work_array(cp.pv, cp.kn)
    states = np.empty((nsteps + 1, cp.n_states))
    commands = np.full(nsteps + 1, np.nan)
    meas = np.empty((nsteps + 1, len(MEASUREMENT_KEYS)))
    valve_flow = np.full((nsteps + 1, 2), np.nan)
    chamber_flow = np.full((nsteps + 1, 2), np.nan)
    mach = np.full((nsteps + 1, 2), np.nan)
    force = np.empty(nsteps + 1)
    vel_f = DifferentiatingFilter(sensors.differentiation_cutoff_Hz, dt)
    acc_f = DifferentiatingFilter(sensors.differentiation_cutoff_Hz, dt)
    p_valve = (int(cp.off[0, K.O_P]), int(cp.off[1, K.O_P]))
    p_ch = (p_valve[0] + cp.node_count(0) - 1, p_valve[1] + cp.node_count(1) - 1)
    p_read = np.array(p_valve + p_ch, np.int64)
    args = (pc, ps, cp.pv, cp.off, cp.kn, cp.km, cp.ka, cp.grid, cp.csup, cp.cexh)
    _, _, _, acc[K.A_FORCE] = K.piston_forces(x[0], x[1], x[p_ch[0]], x[p_ch[1]], cp.pc)
    states[0], force[0] = x, acc[K.A_FORCE]
    raw = tuple(float(v) for v in (x[0], acc[K.A_FORCE], *x[p_read]))
    read_pos, read_f = sensors.position.read, sensors.force.read
    read_v1, read_v2 = sensors.pressure_valve_1.read, sensors.pressure_valve_2.read
    read_c1, read_c2 = sensors.pressure_chamber_1.read, sensors.pressure_chamber_2.read
    for k in range(nsteps + 1):
        t = k * dt
        z = read_pos(raw[0], t)
        vz = vel_f.update(z)
        m = (z, vz, acc_f.update(vz), read_f(raw[1], t), read_v1(raw[2], t), read_v2(raw[3], t),
             read_c1(raw[4], t), read_c2(raw[5], t))
        meas[k] = m
        if progress is not None and (k % PROGRESS_PERIODS == 0 or k == nsteps):
            progress(k, nsteps)
        if k == nsteps:
            break
        u = controller(t, dict(zip(MEASUREMENT_KEYS, m)))
        u = float(u)
        if not math.isfinite(u):
            raise SensorInputError(f"controller returned command {u!r} at t = {t:.6g} s: must be finite")
        u = min(1.0, max(-1.0, u))
        commands[k] = u
        head, bad, over, *raw = K.control_period(k, x, u, nsub, h, dt, *args, ring, head, acc, MAX_VELOCITY_M_S,
                                                 work, p_read, states, valve_flow, chamber_flow, mach, force)
        if over >= 0:
            raise SolverError(f"simulation stopped at t = {t + dt:.6g} s: the side {over + 1} line reached Mach "
                              f"{mach[k, over]:.3g}, beyond the distributed line's range (subsonic flow up to "
                              f"Mach {ps[over, K.S_MACH_LIMIT]:g}; its isothermal ends choke at Mach "
                              f"{1 / math.sqrt(cp.plant.air.gamma):.3f})")
        if bad >= 0:
            raise SensorInputError(f"simulation stopped at t = {t + dt:.6g} s: state {cp.labels[bad]} = "
                              f"{float(x[bad])!r} is not finite or outside its physical range")
    return _dataset(cp, states, commands, meas, valve_flow, chamber_flow, mach, force, dt, nsub, h, p_valve, p_ch)


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


def _dataset(cp, states, commands, meas, valve_flow, chamber_flow, mach, force, dt, nsub, h, p_valve, p_ch):
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
                              {"units": "1", "note": "largest Mach number of the line's flow elements "
                                                     "over the period (0 without flow elements)"}),
            "chamber_temperature": (("time", "side"), _temperatures(cp, states), {"units": "K"}),
            "spool_position": ("time", states[:, int(cp.pc[K.OX]) + K.X_SPOOL],
                               {"units": "1", "note": "the command itself for an ideal spool"}),
            "environment_force": ("time", force, {"units": "N"}),
            "command": ("time", commands, {"units": "1", "note": "valve command held over the period"}),
        },
        coords={"time": ("time", time, {"units": "s"}), "side": side, "state": cp.labels},
        attrs={"rate_Hz": 1.0 / dt, "substeps": nsub, "substep_s": h,
               "line_1": repr(cp.plant.line_1), "line_2": repr(cp.plant.line_2),
               "valve": cp.plant.valve.name, "supply_Pa": cp.plant.supply_Pa},
    )
    for j, key in enumerate(MEASUREMENT_KEYS):
        ds[f"measured_{key}"] = ("time", meas[:, j])
    return ds


def _temperatures(cp, states) -> np.ndarray:
    """Chamber-node gas temperatures T = P V / (m R) (K) of every row of ``states``."""
    ox = int(cp.pc[K.OX])
    act = cp.plant.actuator
    v1, v2 = ((act.volume_1_m3, act.volume_2_m3) if isinstance(act, FixedChambers)
              else act.volumes(states[:, 0]))
    r_gas = cp.plant.air.gas_constant_J_kgK
    out = np.empty((states.shape[0], 2))
    for s, v in enumerate((v1, v2)):
        p = states[:, int(cp.off[s, K.O_P]) + cp.node_count(s) - 1]
        out[:, s] = p * (v + cp.pv[s, cp.node_count(s) - 1]) / (states[:, ox + s] * r_gas)
    return out
