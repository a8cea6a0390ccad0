"""Force-feedback pressure observer of chapter IV (eqs 19-24) and its two baselines.

States are the stored energies x_i = P_i V_i (eq 19) with V_i the chamber volume from the
position reading plus the line volume (eqs 16, 20-21).  The observer integrates

    x_hat_i' = m_hat_i R T + k f_i                                       (eq 22)

with m_hat_i the valve flow (eq 14) computed at the estimated pressures and f_1, f_2 the
expressions of eqs 23-24, which already contain the force error F_hat_p - F_p (DESIGN
section 11: it is not multiplied in again).  F_p is the actuator force measured through eq 18
from the force and position readings: F_p = F_e + M z'' + B z' with z', z'' the filtered
derivatives of the position (first-order filter, 50 Hz, thesis 4.2.3).

Kinds: ``force`` (the observer, k > 0), ``standard`` (k = 0: the open-loop standard model) and
``valve`` (the valve-port pressure readings taken as chamber pressures).

The 2-state system is stepped at the control rate with the linearly implicit Euler rule
x+ = x + h (I - h J)^-1 F(x), J the exact Jacobian (valve-flow slope and the correction's
constant matrix), so any k >= 0 is stable at any step.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numba import njit

from sensor.errors import SensorInputError
from sensor.pneumatic.cylinder import Cylinder
from sensor.pneumatic.valve import port_flow

OBSERVER_KINDS = ("force", "standard", "valve")

#: The standard model's parameters as one named record (SI units): R T, atmosphere, supply, the
#: valve's b, laminar ratio and k_ref, piston areas, stroke, the volumes V0_i (chamber dead volume
#: plus nominal line volume), piston mass M and viscous damping B.  All fields are float64, so the
#: per-sample entry points (observer_update, the controllers' laws) take its float view ``q`` (a
#: plain array: cheap to pass from Python), read it back once with ``q.view(MODEL)[0]`` and hand
#: the record to the functions they call.
MODEL = np.dtype([(name, np.float64) for name in (
    "rt", "p_atm", "p_supply", "b_crit", "r_lam", "k_ref", "area_1", "area_2", "area_rod", "stroke",
    "volume_1_0", "volume_2_0", "mass", "viscous")])


@dataclass(frozen=True)
class ObserverModel:
    """The standard model the observer (and the model-based controllers) use, SI units.

    Chamber i volume V_i = V0_i + A_i * stroke fraction (eqs 20-21): V_1 = V0_1 + A_1 z,
    V_2 = V0_2 + A_2 (stroke - z), V0_i = the chamber's dead volume plus the nominal line
    volume (eq 16).  M, B: piston mass and viscous damping of eq 18.
    """

    q: np.ndarray
    grid: np.ndarray
    supply_conductance: np.ndarray
    exhaust_conductance: np.ndarray
    line_volume_m3: tuple[float, float]
    line_length_m: tuple[float, float]
    line_bore_m: tuple[float, float]
    viscosity_Pa_s: float

    @classmethod
    def from_plant(cls, plant) -> "ObserverModel":
        """Nominal parameters of a :class:`~sensor.pneumatic.plant.Plant` (cylinder only)."""
        act, air, valve = plant.actuator, plant.air, plant.valve
        if not isinstance(act, Cylinder):
            raise SensorInputError(f"plant actuator = {type(act).__name__}: the observer needs a Cylinder "
                              "(piston force and moving chamber volumes, eqs 17-21)")
        rec = np.zeros(1, MODEL)
        p = rec[0]
        p["rt"], p["p_atm"], p["p_supply"] = air.rt, air.atmosphere_Pa, plant.supply_Pa
        p["b_crit"], p["r_lam"], p["k_ref"] = valve.critical_ratio, valve.laminar_ratio, valve.k_ref
        p["area_1"], p["area_2"], p["area_rod"], p["stroke"] = act.area_1_m2, act.area_2_m2, act.rod_area_m2, act.stroke_m
        p["volume_1_0"] = act.dead_volume_1_m3 + plant.line_1.volume_m3
        p["volume_2_0"] = act.dead_volume_2_m3 + plant.line_2.volume_m3
        p["mass"], p["viscous"] = act.piston_mass_kg, act.viscous_N_s_m
        q = rec.view(np.float64)
        grid, cs, ce = valve.arrays()
        lines = (plant.line_1, plant.line_2)
        return cls(q, grid, cs, ce, tuple(float(ln.volume_m3) for ln in lines),
                   tuple(float(ln.length_m) for ln in lines), tuple(float(ln.bore_m) for ln in lines),
                   air.viscosity_Pa_s)

    @property
    def params(self) -> np.void:
        """The parameters by name (the :data:`MODEL` record of ``q``)."""
        return self.q.view(MODEL)[0]

    def volumes(self, z_m: float) -> tuple[float, float]:
        """Chamber plus line volumes (m^3) at piston position z (eqs 20-21)."""
        return volumes(z_m, self.params)

    def force_capacity_N(self) -> tuple[float, float]:
        """(lowest, highest) actuator force (N): one chamber at supply, the other at atmosphere
        (eq 17): -(P_s - P_atm) A_2 and (P_s - P_atm) A_1."""
        p = self.params
        dp = p["p_supply"] - p["p_atm"]
        return -dp * p["area_2"], dp * p["area_1"]

    def gain_for_rate(self, rate_Hz: float, z_m: float | None = None) -> float:
        """Observer gain k (m^6/s) that puts the correction's pole at ``rate_Hz`` at position z
        (default mid-stroke): the correction's Jacobian in x has the single nonzero eigenvalue
        -k (A_1 / (V_1^2 A_2) + A_2 / (V_2^2 A_1))."""
        if not (math.isfinite(rate_Hz) and rate_Hz >= 0):
            raise SensorInputError(f"observer rate_Hz = {rate_Hz!r}: must be a finite number >= 0")
        p = self.params
        z = p["stroke"] / 2 if z_m is None else z_m
        v1, v2 = self.volumes(z)
        a1, a2 = p["area_1"], p["area_2"]
        return 2 * math.pi * rate_Hz / (a1 / (v1 * v1 * a2) + a2 / (v2 * v2 * a1))


@njit(cache=True)
def volumes(z, p):
    """(V_1, V_2) in m^3: chamber plus line volume at position z (eqs 16, 20-21); p: a MODEL record."""
    return p.volume_1_0 + p.area_1 * z, p.volume_2_0 + p.area_2 * (p.stroke - z)


@njit(cache=True)
def actuator_force(p1, p2, p):
    """F_p = P_1 A_1 - P_2 A_2 - P_atm A_rod in N (eq 17)."""
    return p1 * p.area_1 - p2 * p.area_2 - p.p_atm * p.area_rod


@njit(cache=True)
def measured_actuator_force(force_N, velocity_m_s, acceleration_m_s2, q):
    """F_p = F_e + M z'' + B z' in N from the readings (eq 18, Coulomb friction neglected)."""
    p = q.view(MODEL)[0]
    return force_N + p.mass * acceleration_m_s2 + p.viscous * velocity_m_s


@njit(cache=True)
def correction(p1_hat, p2_hat, v1, v2, fp_measured, p):
    """(f_1, f_2) of eqs 23-24 in Pa/m^3; they contain the force error F_hat_p - F_p."""
    err = actuator_force(p1_hat, p2_hat, p) - fp_measured
    return -err / (v1 * p.area_2), err / (v2 * p.area_1)


@njit(cache=True)
def observer_rhs(x1, x2, u, v1, v2, fp_measured, k, p, grid, csup, cexh):
    """d(x_hat)/dt of eq 22 (W) and its Jacobian (1/s) as (d1, d2, j11, j12, j21, j22)."""
    p1, p2 = x1 / v1, x2 / v2
    m1, dm1 = port_flow(u, grid, csup, cexh, p.b_crit, p.r_lam, p.p_supply, p1, p.p_atm, p.k_ref)
    m2, dm2 = port_flow(-u, grid, csup, cexh, p.b_crit, p.r_lam, p.p_supply, p2, p.p_atm, p.k_ref)
    f1, f2 = correction(p1, p2, v1, v2, fp_measured, p)
    rt, a1, a2 = p.rt, p.area_1, p.area_2
    c12 = k / (v1 * v2)
    return (m1 * rt + k * f1, m2 * rt + k * f2,
            rt * dm1 / v1 - k * a1 / (v1 * v1 * a2), c12,
            c12, rt * dm2 / v2 - k * a2 / (v2 * v2 * a1))


@njit(cache=True)
def observer_step(x1, x2, u, z, fp_measured, k, h, p, grid, csup, cexh):
    """One linearly implicit Euler step of h seconds; returns the new (x_hat_1, x_hat_2)."""
    v1, v2 = volumes(z, p)
    d1, d2, j11, j12, j21, j22 = observer_rhs(x1, x2, u, v1, v2, fp_measured, k, p, grid, csup, cexh)
    a, b, c, d = 1.0 - h * j11, -h * j12, -h * j21, 1.0 - h * j22
    det = a * d - b * c
    return x1 + h * (d * d1 - b * d2) / det, x2 + h * (a * d2 - c * d1) / det


class PressureObserver:
    """Chamber-pressure estimator of one of :data:`OBSERVER_KINDS`, updated once per sample.

    ``gain_m6_s``: k of eq 22 for kind ``force`` (ignored otherwise); ``initial_Pa``: the
    starting estimates (default: the atmosphere, the plant's rest state, so plant and
    estimator start from one physical state; the thesis' plots start from zero); ``gain_on_s``: time at which the
    correction is switched on (before it the observer runs as the standard model, Figure 27).
    """

    def __init__(self, model: ObserverModel, kind: str = "force", gain_m6_s: float = 0.0,
                 dt_s: float = 1e-3, initial_Pa: tuple[float, float] | None = None, gain_on_s: float = 0.0):
        if kind not in OBSERVER_KINDS:
            raise SensorInputError(f"observer = {kind!r}: must be one of {', '.join(OBSERVER_KINDS)}")
        if not (math.isfinite(gain_m6_s) and gain_m6_s >= 0):
            raise SensorInputError(f"observer gain k = {gain_m6_s!r} m^6/s: must be a finite number >= 0 "
                              "(k < 0 makes eq 34 positive and the observer unstable)")
        if not (math.isfinite(dt_s) and dt_s > 0):
            raise SensorInputError(f"observer dt_s = {dt_s!r}: must be a positive finite number")
        self.model, self.kind, self.dt = model, kind, float(dt_s)
        self.k = float(gain_m6_s) if kind == "force" else 0.0
        self.gain_on_s = float(gain_on_s)
        if initial_Pa is None:
            initial_Pa = (model.params["p_atm"], model.params["p_atm"])
        self._p0 = tuple(float(p) for p in initial_Pa)
        self._limit = 100.0 * float(model.params["p_supply"])   # runaway bound on an estimate (Pa)
        self._x: tuple | None = None      # (x_hat_1, x_hat_2, P_hat_1, P_hat_2, F_p) of observer_update
        self.pressures = self._p0
        self.fp_measured = 0.0

    def update(self, t: float, m: dict, u_prev: float) -> tuple[float, float]:
        """Advance to the sample at t with the previous command u_prev; returns (P_hat_1, P_hat_2)."""
        q = self.model.q
        if self.kind == "valve":
            self.fp_measured = measured_actuator_force(m["force_N"], m["velocity_m_s"], m["acceleration_m_s2"], q)
            self.pressures = (m["pressure_valve_1_Pa"], m["pressure_valve_2_Pa"])
            return self.pressures
        first = self._x is None
        x = self._p0 if first else self._x
        self._x = _, _, p1, p2, self.fp_measured = observer_update(
            x[0], x[1], first, u_prev, m["position_m"], m["force_N"], m["velocity_m_s"], m["acceleration_m_s2"],
            self.k if t >= self.gain_on_s else 0.0, self.dt, q, self.model.grid, self.model.supply_conductance,
            self.model.exhaust_conductance)
        limit = self._limit
        if not (abs(p1) < limit and abs(p2) < limit):       # False for NaN too
            i, p = (1, p1) if not abs(p1) < limit else (2, p2)
            raise SensorInputError(f"observer stopped at t = {t:.6g} s: estimated chamber pressure "
                                   f"P_hat_{i} = {p!r} Pa left its range (|P| < {limit:.3g} Pa)")
        self.pressures = (p1, p2)
        return self.pressures


@njit(cache=True)
def observer_update(x1, x2, first, u_prev, z, force_N, velocity_m_s, acceleration_m_s2, k, h, q, grid, csup, cexh):
    """One sample of the observer: F_p from the readings (eq 18), then (unless ``first``, when
    x1, x2 are the starting pressures) one :func:`observer_step`.  Returns (x_hat_1, x_hat_2,
    P_hat_1, P_hat_2, F_p)."""
    fp = measured_actuator_force(force_N, velocity_m_s, acceleration_m_s2, q)
    p = q.view(MODEL)[0]
    v1, v2 = volumes(z, p)
    if first:
        x1, x2 = x1 * v1, x2 * v2
    else:
        x1, x2 = observer_step(x1, x2, u_prev, z, fp, k, h, p, grid, csup, cexh)
    return x1, x2, x1 / v1, x2 / v2, fp
