"""Force controllers of chapters IV and V, each a callable ``controller(t, measurements) -> u``
for :func:`sensor.pneumatic.simulate.simulate` (u in [-1, 1], SI readings).

* :class:`PIForce` - direct PI force control, e = F_d - F_e (section 4.2.3, Figure 15a).
* :class:`Impedance` - F_d = m_d z~'' + b_d z~' + k_d z~, z~ = z_d - z (eqs 41-42), e_c = F_d - F_e
  (eq 43) fed to the PI law (Figure 15b).
* :class:`SlidingMode` - s = e + lambda int e (eqs 45, 50), equivalent conductance from the
  model with estimated pressures (eqs 47, 51, 53) plus eta sat(s / phi) (eq 48, sat of
  DESIGN section 12), turned into a command by the inverse valve calibration.
* :class:`LineModel` - the cascaded controller of section 5.3 (eqs 63-72): a two-volume line
  model per side (eqs 54-58) driven by the valve-port pressures estimates the chamber pressure
  and chamber flow; the outer loop asks for a valve force F_vd (eq 70), the inner loop makes
  F_V = P_v1 A1 - P_v2 A2 (eq 67) track it (eq 72).
* :func:`smc_gains`, :func:`line_model_gains` - the gains of section 5.4.2, derived per line
  length from the line's dynamics (:func:`line_dynamics`) instead of tuned by hand.  The
  line-model controller comes as the thesis wrote it (``line-model``: k_m = 0, PI inner loop)
  and with the project's line-flow damping (``line-model-damped``, k_m = 2 w_L).

Each controller owns a :class:`~sensor.pneumatic.observer.PressureObserver` it updates every
sample (for SMC its pressures enter the law; for PI and impedance it runs alongside, decoupled,
as in the thesis) and logs one row per sample in ``rows`` with the names in ``channels``.

Unit corrections (DESIGN section 12 and this module): eqs 68 and 72 carry R T between mass flow
and force rate; eqs 47, 51 and 69 write M z'' + B z' where the force *rate* needs M z''' + B z'';
B z'' is kept, M z''' (jerk, not measured; M = 50 g) is dropped; h_bar of eq 65 carries the A/L
of eq 63 so it is a rate (1/s); F_p = F_V - P_atm A_rod at rest (eq 17), so P_atm A_rod is added to F_vd (the "upward
shift" of section 5.6).  Chamber 2's flow enters with a minus sign (both flows count into their
chambers).
"""
from __future__ import annotations

import math
import re
from dataclasses import dataclass

import numpy as np
from numba import njit

from sensor.errors import SensorInputError
from sensor.pneumatic._kernel import steady_coefficient
from sensor.pneumatic.observer import (
    MODEL,
    ObserverModel,
    PressureObserver,
    volumes,
)
from sensor.pneumatic.sensors import DifferentiatingFilter
from sensor.pneumatic.valve import orifice_flow

CONTROLLERS = ("pi", "impedance", "smc", "line-model", "line-model-damped")
LINE_MODEL_VARIANTS = {"line-model": "thesis", "line-model-damped": "damped"}
REFERENCE_KINDS = ("sine", "step", "square")
MAX_REFERENCE_HZ = 100.0  # sampled at 1 kHz, a faster reference aliases (and no valve-line loop follows it)
MAX_REFERENCE_N = 1e5     # hard bound on a reference force; the capacity check warns far below it


# --- references -------------------------------------------------------------------------------

@dataclass(frozen=True)
class Reference:
    """Desired force (N) over time: offset + amplitude * shape(t).

    shape: sin(2 pi f t) (``sine``), sign(sin(2 pi f t)) (``square``), or 0 before
    ``step_s`` and 1 after (``step``)."""

    kind: str
    frequency_Hz: float = 0.0
    amplitude_N: float = 24.0
    offset_N: float = 0.0
    step_s: float = 0.5

    def __post_init__(self) -> None:
        if self.kind not in REFERENCE_KINDS:
            raise SensorInputError(f"reference kind = {self.kind!r}: must be one of {', '.join(REFERENCE_KINDS)}")
        if self.kind != "step" and not (math.isfinite(self.frequency_Hz) and 0 < self.frequency_Hz <= MAX_REFERENCE_HZ):
            raise SensorInputError(f"reference frequency = {self.frequency_Hz!r} Hz: must be a positive finite number "
                                   f"<= {MAX_REFERENCE_HZ:g} Hz (a tenth of the 1 kHz control rate)")
        for name in ("amplitude_N", "offset_N", "step_s"):
            if not math.isfinite(getattr(self, name)):
                raise SensorInputError(f"reference {name} = {getattr(self, name)!r}: must be finite")
        for name in ("amplitude_N", "offset_N"):
            if abs(getattr(self, name)) > MAX_REFERENCE_N:
                raise SensorInputError(f"reference {name} = {getattr(self, name)!r} N: must lie within "
                                       f"+-{MAX_REFERENCE_N:g} N (the actuators here make well under 1 kN)")
        object.__setattr__(self, "_w", 2 * math.pi * self.frequency_Hz)     # rad/s, for value_and_rate

    def value_and_rate(self, t: float) -> tuple[float, float]:
        """(F_d, dF_d/dt) in N and N/s at t: :meth:`value` and :meth:`rate` in one call (the loop's)."""
        if self.kind == "sine":
            wt = self._w * t
            return (self.offset_N + self.amplitude_N * math.sin(wt),
                    self.amplitude_N * self._w * math.sin(wt + math.pi / 2))
        return self.value(t), 0.0

    def derivatives(self, t: float) -> tuple[float, float, float, float]:
        """F_d and its first three time derivatives at t (N, N/s, N/s^2, N/s^3): :meth:`value` and
        :meth:`rate` of orders 1-3 in one call."""
        if self.kind == "sine":
            w, wt, a = self._w, self._w * t, self.amplitude_N
            return (self.offset_N + a * math.sin(wt), a * w * math.sin(wt + math.pi / 2),
                    a * w**2 * math.sin(wt + 2 * math.pi / 2), a * w**3 * math.sin(wt + 3 * math.pi / 2))
        return self.value(t), 0.0, 0.0, 0.0

    def value(self, t: float) -> float:
        if self.kind == "sine":
            return self.offset_N + self.amplitude_N * math.sin(2 * math.pi * self.frequency_Hz * t)
        if self.kind == "square":
            return self.offset_N + self.amplitude_N * (1.0 if math.sin(2 * math.pi * self.frequency_Hz * t) >= 0 else -1.0)
        return self.offset_N + (self.amplitude_N if t >= self.step_s else 0.0)

    def rate(self, t: float, order: int = 1) -> float:
        """d^n F_d / dt^n in N/s^n, n = ``order`` >= 1 (zero between the jumps of step and square)."""
        if self.kind == "sine":
            w = 2 * math.pi * self.frequency_Hz
            return self.amplitude_N * w**order * math.sin(w * t + order * math.pi / 2)
        return 0.0

    def values(self, t: np.ndarray) -> np.ndarray:
        return np.array([self.value(float(ti)) for ti in t])

    @property
    def peak_N(self) -> tuple[float, float]:
        """(lowest, highest) value."""
        lo = self.offset_N - (abs(self.amplitude_N) if self.kind != "step" else max(0.0, -self.amplitude_N))
        hi = self.offset_N + (abs(self.amplitude_N) if self.kind != "step" else max(0.0, self.amplitude_N))
        return lo, hi

    @property
    def label(self) -> str:
        return "step" if self.kind == "step" else f"{self.kind}:{self.frequency_Hz:g}Hz"


def parse_reference(text: str, amplitude_N: float = 24.0, offset_N: float = 0.0, step_s: float = 0.5) -> Reference:
    """``sine:1Hz``, ``square:0.5Hz`` or ``step`` (see :class:`Reference`)."""
    m = re.fullmatch(r"\s*(sine|square)\s*:\s*([0-9.eE+-]+)\s*(?:hz|Hz|HZ)?\s*", text)
    if m:
        try:
            f = float(m.group(2))
        except ValueError:
            raise SensorInputError(f"reference = {text!r}: the frequency must be a number, e.g. sine:1Hz") from None
        return Reference(m.group(1), f, amplitude_N, offset_N, step_s)
    if text.strip() == "step":
        return Reference("step", 0.0, amplitude_N, offset_N, step_s)
    raise SensorInputError(f"reference = {text!r}: must be sine:<f>Hz, square:<f>Hz or step")


# --- valve inverse (conductance -> command) and flow functions ---------------------------------------

def valve_inverse(model: ObserverModel) -> tuple[np.ndarray, np.ndarray]:
    """Inverse of the valve's flow-coefficient table C(u) (eq 14): the (conductance, command) table
    of port 1's supply orifice for u >= 0, monotone, starting at
    the last command of the closed (or leakage) band so an overlap is stepped over."""
    g, c = model.grid, model.supply_conductance
    pos = g >= 0
    gp, cp = g[pos], np.maximum.accumulate(c[pos])
    i0 = int(np.flatnonzero(cp == cp[0])[-1])
    keep = np.concatenate([[True], np.diff(cp[i0:]) > 0])
    return cp[i0:][keep], gp[i0:][keep]


@njit(cache=True)
def command_for(conductance, cal_c, cal_u):
    """Command u in [-1, 1] whose net conductance is the signed ``conductance`` (m^3/(s Pa))."""
    u = np.interp(abs(conductance), cal_c, cal_u)
    return u if conductance >= 0.0 else -u


@njit(cache=True)
def psi(pu, pd, p):
    """Flow per unit conductance psi(P_u, P_d) (kg/(s m^3/(s Pa))) of eq 88; p: a MODEL record."""
    return orifice_flow(1.0, p.b_crit, p.r_lam, pu, pd, p.k_ref)[0]


@njit(cache=True)
def sat(s, phi):
    """sat(s / phi) of eq 52 as corrected (DESIGN section 12): s/phi inside |s| <= phi, sign(s) out."""
    if abs(s) <= phi:
        return s / phi
    return 1.0 if s > 0 else -1.0


@njit(cache=True)
def smc_conductance(force_rate_N_s, p1, p2, z, v, p):
    """Signed conductance that makes the actuator force rise at ``force_rate_N_s`` with chamber
    pressures p1, p2 (eqs 47/51, 53): F_p' = C R T psi_T - A1 P1 V1'/V1 + A2 P2 V2'/V2."""
    v1, v2 = volumes(z, p)
    a1, a2 = p.area_1, p.area_2
    need = force_rate_N_s + a1 * p1 * (a1 * v) / v1 - a2 * p2 * (-a2 * v) / v2
    if need >= 0.0:
        den = psi(p.p_supply, p1, p) * a1 / v1 + psi(p2, p.p_atm, p) * a2 / v2
    else:
        den = psi(p1, p.p_atm, p) * a1 / v1 + psi(p.p_supply, p2, p) * a2 / v2
    return need / (p.rt * max(den, 1e-300))


@njit(cache=True)
def smc_law(fd, fd_rate, p1, p2, force, z, v, acc, integral, lam, eta, phi, dt, q, cal_c, cal_u):
    """One sample of :class:`SlidingMode`: s = e + lambda int e, the conductance that sets
    F_e' = F_d' + lambda e + eta sat(s / phi) (+ B z'' of eq 47) and its command.  The sliding
    variable's integral has no anti-windup.  Returns (u, s, new integral)."""
    p = q.view(MODEL)[0]
    e = fd - force
    s = e + lam * integral
    rate = fd_rate + lam * e + eta * sat(s, phi) + p.viscous * acc
    u = command_for(smc_conductance(rate, p1, p2, z, v, p), cal_c, cal_u)
    return u, s, integral + e * dt


@njit(cache=True)
def line_model_step(pc, mc, pv, vnode, h, inertance, bore, mu, rt):
    """One semi-implicit step of the two-volume line model of one side (eqs 54-58):
    flow first (friction implicit), then the chamber node from the new flow.  vnode = (old,
    new) node volume V_c + V_L/2.  Returns (P_c, m_c, f)."""
    rho = (pv + pc) / (2.0 * rt)
    f = steady_coefficient(mc, mu / rho, bore, 0, mu)
    mc_new = (mc + h * inertance * (pv - pc)) / (1.0 + h * f)
    pc_new = (pc * vnode[0] + h * mc_new * rt) / vnode[1]
    return pc_new, mc_new, f


# --- gains per line length (section 5.4.2) ----------------------------------------------------------

SMC_SLOPE_FRACTION = 1.0 / 7.0   # eta/phi = w_L / 7
SMC_PHI_N = 20.0                 # boundary-layer width (N), the reference amplitude's scale
SMC_LAMBDA_PER_S = 2.0
OUTER_RATE_FRACTION = 0.75       # lambda + h_bar k_p1 = 0.75 w_L
OUTER_LAMBDA_PER_S = 10.0
OUTER_INTEGRAL_PER_S = 1.0       # k_i1, the outer loop's integral gain (LineModel's default)
FLOW_DAMPING_RATIO = 1.0         # k_m = 2 zeta w_L
INNER_SAMPLE_GAIN = 0.4          # k_p2 L / (2 c) at the longest design line
INNER_DESIGN_LENGTH_M = 10.0     # the longest line of chapter V: one k_p2 for every line up to it


@dataclass(frozen=True)
class LineDynamics:
    """Nominal two-volume line model of a plant (eqs 54-58, 63-65), mean of both sides, at
    mid-stroke, zero flow and the mean pressure (P_s + P_atm) / 2.

    natural_rad_s: w_L = sqrt((A/L) R T / V_bar), V_bar the chamber node volume V_c + V_L/2;
    friction_per_s: laminar f = 32 nu / d^2 (eq 54); h_bar_per_s: w_L^2 / f (eq 65 with the A/L
    of eq 63); speed_of_sound_m_s: c = sqrt(gamma R T); length_m: the longer line."""

    natural_rad_s: float
    friction_per_s: float
    h_bar_per_s: float
    speed_of_sound_m_s: float
    length_m: float


def line_dynamics(plant) -> LineDynamics:
    """:class:`LineDynamics` of a :class:`~sensor.pneumatic.plant.Plant`."""
    model = ObserverModel.from_plant(plant)
    q = model.params
    z = q["stroke"] / 2
    v1, v2 = model.volumes(z)
    vbar = 0.5 * (v1 + v2) - 0.25 * sum(model.line_volume_m3)     # V_c + V_L / 2, mean of the sides
    length = 0.5 * sum(model.line_length_m)
    bore = 0.5 * sum(model.line_bore_m)
    wl2 = math.pi * bore * bore / 4 / length * q["rt"] / vbar
    rho = 0.5 * (q["p_supply"] + q["p_atm"]) / q["rt"]
    f = 32.0 * model.viscosity_Pa_s / rho / (bore * bore)
    return LineDynamics(float(math.sqrt(wl2)), float(f), float(wl2 / f), plant.air.speed_of_sound, max(model.line_length_m))


def smc_gains(plant, slope_fraction: float = SMC_SLOPE_FRACTION) -> dict:
    """SMC gains for the plant's lines: the boundary-layer slope eta/phi (the rate of s' =
    -(eta/phi) s inside the layer, 1/s) is w_L/7, a margin below the lightly damped line mode the
    standard model ignores; phi = 20 N, lambda = 2 /s.  Measured on the distributed 20-segment
    plant, Enfield valve: w_L/4 and w_L/5 limit-cycle after a 24 N step at 7.25 and 10 m
    (force-error lines of 1.5-2.4 N above 2.5 Hz), w_L/7 does not (below 0.05 N).
    ``slope_fraction``: another eta/phi / w_L (the tuning search of :mod:`.tuning`)."""
    ld = line_dynamics(plant)
    slope = slope_fraction * ld.natural_rad_s
    return {"lam_per_s": SMC_LAMBDA_PER_S, "eta_N_s": slope * SMC_PHI_N, "phi_N": SMC_PHI_N}


def line_model_gains(plant, variant: str = "thesis", outer_fraction: float = OUTER_RATE_FRACTION,
                     outer_integral_per_s: float = OUTER_INTEGRAL_PER_S) -> dict:
    """Line-model controller gains for the plant's lines (section 5.4.2: inner loop first, one
    inner gain set for all lengths; outer loop per length).  The thesis gives no numbers, only
    the procedure; these rules stand in for its hand tuning.

    ``variant``: ``thesis`` is eqs 70 and 72 as written (k_m = 0, the inner loop a PI as eq 73
    says); ``damped`` adds the project's line-flow damping k_m = 2 zeta w_L, zeta = 1 (the flow
    term critically damps the line mode, see :class:`LineModel`), all else equal.

    * k_p2 = 2 g c / max(L, 10 m), g = 0.4: at one-sample time scales the valve port sees the
      line's wave impedance rho c / A, not the half line volume A L / 2 the inner loop (eq 72)
      assumes, so its per-sample loop gain is k_p2 L / (2 c); held at 0.4 on the longest line
      of chapter V, one value (27.5 /s) for all lines up to 10 m.  On the 20-segment
      distributed plant a 500 Hz inner-loop oscillation appears at 5 m from k_p2 ~ 34 /s, at
      10 m from ~ 65 /s; its onset jumps with the segment count, so k_p2 is not raised.
    * k_i2 = k_p2^2 / 4: eq 73's PI error dynamics e_2'' + k_p2 e_2' + k_i2 e_2 = 0 critically
      damped.
    * k_p1 = (0.75 w_L - lambda) / h_bar (>= 0), lambda = 10 /s: the nominal outer-loop rate
      lambda + h_bar k_p1 (eq 71) is three quarters of the line mode, so the outer loop stays
      below the line it drives (h_bar at 2 m is 19 times that at 10 m); ``outer_fraction``
      another fraction (the tuning search of :mod:`.tuning`, inner loop held).
    * k_i1 = 1 /s (``outer_integral_per_s``; the tuning search also tries 0)."""
    if variant not in ("thesis", "damped"):
        raise SensorInputError(f"line-model gain variant = {variant!r}: must be thesis or damped")
    ld = line_dynamics(plant)
    kp1 = max(0.0, (outer_fraction * ld.natural_rad_s - OUTER_LAMBDA_PER_S) / ld.h_bar_per_s)
    kp2 = 2 * INNER_SAMPLE_GAIN * ld.speed_of_sound_m_s / max(ld.length_m, INNER_DESIGN_LENGTH_M)
    km = 2 * FLOW_DAMPING_RATIO * ld.natural_rad_s if variant == "damped" else 0.0
    return {"lam_per_s": OUTER_LAMBDA_PER_S, "kp1": kp1, "ki1_per_s": outer_integral_per_s, "kp2_per_s": kp2,
            "ki2_per_s2": kp2 * kp2 / 4, "flow_rate_per_s": km}


# --- controllers ----------------------------------------------------------------------------------

class _Loop:
    """Common part: observer update, reference, anti-windup integral, logging."""

    channels: tuple[str, ...] = ("desired_force_N", "estimated_pressure_1_Pa", "estimated_pressure_2_Pa",
                                 "measured_actuator_force_N")

    def __init__(self, model: ObserverModel, reference: Reference, observer: PressureObserver, dt_s: float):
        self.model, self.reference, self.observer, self.dt = model, reference, observer, float(dt_s)
        self.u = 0.0
        self.integral = 0.0
        self.rows: list[tuple[float, ...]] = []

    def _integrate(self, e: float, u_unclipped: float) -> None:
        """Integrate e unless the command is saturated and e would push it further (anti-windup)."""
        if abs(u_unclipped) < 1.0 or (u_unclipped > 0) != (e > 0):
            self.integral += e * self.dt

    def desired(self, t: float, m: dict) -> tuple[float, float]:
        """(F_d, dF_d/dt) in N and N/s."""
        return self.reference.value_and_rate(t)

    def __call__(self, t: float, m: dict) -> float:
        p1, p2 = self.observer.update(t, m, self.u)
        fd, fd_rate = self.desired(t, m)
        u, extra = self.law(t, m, fd, fd_rate, p1, p2)
        self.rows.append((fd, p1, p2, self.observer.fp_measured) + extra)
        self.u = min(1.0, max(-1.0, u))
        return self.u


class PIForce(_Loop):
    """u = k_p e + k_i int e, e = F_d - F_e (gains in 1/N and 1/(N s))."""

    def __init__(self, model, reference, observer, dt_s=1e-3, kp_per_N=0.005, ki_per_N_s=0.05):
        super().__init__(model, reference, observer, dt_s)
        _check_gains(kp_per_N=kp_per_N, ki_per_N_s=ki_per_N_s)
        self.kp, self.ki = kp_per_N, ki_per_N_s

    def law(self, t, m, fd, fd_rate, p1, p2):
        e = fd - m["force_N"]
        u = self.kp * e + self.ki * self.integral
        self._integrate(e, u)
        return u, ()


class Impedance(PIForce):
    """Desired force of a critically damped impedance about z_d (eqs 41-43) tracked by the PI law.

    z_d = rest_m + F_ref(t) / k_d, so the reference's newtons are the spring force k_d z~ asked
    for; z~ = z_d - z with z_d', z_d'' from the reference (zero between the jumps of a square).

    The rate returned with F_d (the F_d' of eqs 46-47 for :class:`SlidingMode`) is the part the
    reference moves, k_d z_d' + b_d z_d'' + m_d z_d^(3); the measured part -k_d z' - b_d z'' is
    left to the robustness term as a bounded disturbance (section 4.2.2).  Fed forward it reaches
    the piston only after the lines' transport delay L/c and limit-cycles near c/(2L) (23.5 Hz,
    21 N RMS force error at 7.25 m, for every eta tried)."""

    def __init__(self, model, reference, observer, dt_s=1e-3, kp_per_N=0.005, ki_per_N_s=0.05,
                 stiffness_N_m=2000.0, mass_kg=0.05, rest_m=None):
        super().__init__(model, reference, observer, dt_s, kp_per_N, ki_per_N_s)
        _check_gains(stiffness_N_m=stiffness_N_m, mass_kg=mass_kg)
        self.kd, self.md = stiffness_N_m, mass_kg
        self.bd = 2.0 * math.sqrt(stiffness_N_m * mass_kg)     # critical damping
        self.rest = model.params["stroke"] / 2 if rest_m is None else rest_m

    def desired(self, t, m):
        f, f1, f2, f3 = self.reference.derivatives(t)
        zd = self.rest + f / self.kd
        fd = (self.kd * (zd - m["position_m"]) + self.bd * (f1 / self.kd - m["velocity_m_s"])
              + self.md * (f2 / self.kd - m["acceleration_m_s2"]))
        return fd, f1 + (self.bd * f2 + self.md * f3) / self.kd


class SlidingMode(_Loop):
    """Sliding-mode force control with the observer's pressures (eqs 45-53).

    s = e + lambda int e; the conductance sets F_e' = F_d' + lambda e + eta sat(s / phi), i.e.
    s' = -eta sat(s / phi); lambda (1/s), eta (N/s), phi (N).  With ``impedance`` set (an
    :class:`Impedance` for its desired force) it is the observer-based impedance controller of
    section 4.3."""

    def __init__(self, model, reference, observer, dt_s=1e-3, lam_per_s=2.0, eta_N_s=600.0, phi_N=20.0,
                 impedance: Impedance | None = None):
        super().__init__(model, reference, observer, dt_s)
        _check_gains(lam_per_s=lam_per_s, eta_N_s=eta_N_s, phi_N=phi_N)
        self.lam, self.eta, self.phi = lam_per_s, eta_N_s, phi_N
        self.cal_c, self.cal_u = valve_inverse(model)
        self.impedance = impedance

    def desired(self, t, m):
        return self.impedance.desired(t, m) if self.impedance else super().desired(t, m)

    def law(self, t, m, fd, fd_rate, p1, p2):
        u, s, self.integral = smc_law(fd, fd_rate, p1, p2, m["force_N"], m["position_m"], m["velocity_m_s"],
                                      m["acceleration_m_s2"], self.integral, self.lam, self.eta, self.phi, self.dt,
                                      self.model.q, self.cal_c, self.cal_u)
        return u, (s,)

    channels = _Loop.channels + ("sliding_variable_N",)


class LineModel(_Loop):
    """Cascaded line-model controller (eqs 63-72) with the unit corrections of the module doc.

    Outer loop, eq 70 as written: F_vd = F_p + P_atm A_rod + (lambda e_1 + F_d' + G_1) / h_bar
    + k_p1 e_1 + k_i1 w_1 (lambda 1/s, k_p1 dimensionless, k_i1 1/s), F_p from the line model's
    chamber pressures; in the nominal model e_1' = -(lambda + h_bar k_p1) e_1 - h_bar k_i1 w_1.
    Inner loop: the signed conductance making F_V' = F_vd' + k_p2 e_2 + k_i2 w_2 through eqs 56
    and 67 (R T kept); in F_vd' the chamber-force rate comes from the line model (eq 55) and the
    rest from a first-order filtered derivative (``derivative_cutoff_Hz``).

    ``flow_rate_per_s`` (k_m, 1/s; 0 = eq 70 as written) adds the line inertia the thesis neglects
    (5.3.1): F_vd += (k_m - f) (h_bar shift - phi) / w_L^2, phi the line model's chamber-flow force
    rate, w_L^2 = (A/L) R T / V_bar.  Without it the flow coasts after F_V reaches F_vd and, where
    w_L >> f (short lines), the outer loop oscillates even on the controller's own model."""

    channels = _Loop.channels + ("virtual_input_desired_N", "virtual_input_N", "line_model_pressure_1_Pa",
                                 "line_model_pressure_2_Pa", "h_bar_per_s")

    def __init__(self, model, reference, observer, dt_s=1e-3, lam_per_s=10.0, kp1=0.3, ki1_per_s=1.0,
                 kp2_per_s=60.0, ki2_per_s2=0.0, derivative_cutoff_Hz=20.0, flow_rate_per_s=0.0):
        super().__init__(model, reference, observer, dt_s)
        _check_gains(lam_per_s=lam_per_s, kp1=kp1, ki1_per_s=ki1_per_s, kp2_per_s=kp2_per_s, ki2_per_s2=ki2_per_s2,
                     flow_rate_per_s=flow_rate_per_s)
        self.cal_c, self.cal_u = valve_inverse(model)
        fvd_rate = DifferentiatingFilter(derivative_cutoff_Hz, dt_s)     # its recursion runs in the kernel
        q = model.params
        half = [vl / 2 for vl in model.line_volume_m3]
        inertance = [math.pi * d * d / 4 / ln for d, ln in zip(model.line_bore_m, model.line_length_m)]
        rec = np.zeros(1, LM_PARAMS)
        g = rec[0]
        g["dt"], g["lam"], g["kp1"], g["ki1"] = dt_s, lam_per_s, kp1, ki1_per_s
        g["kp2"], g["ki2"], g["km"] = kp2_per_s, ki2_per_s2, flow_rate_per_s
        g["dead_1"], g["dead_2"] = q["volume_1_0"] - model.line_volume_m3[0], q["volume_2_0"] - model.line_volume_m3[1]
        g["half_1"], g["half_2"], g["inertance_1"], g["inertance_2"] = half[0], half[1], inertance[0], inertance[1]
        g["bore_1"], g["bore_2"], g["mu"] = model.line_bore_m[0], model.line_bore_m[1], model.viscosity_Pa_s
        g["filter_a"], g["filter_b"] = fvd_rate.coefficients
        self.par = rec.view(np.float64)
        self.state = np.zeros(1, LM_STATE).view(np.float64)      # see line_model_law

    def law(self, t, m, fd, fd_rate, p1, p2):
        u, fvd, fv, pc1, pc2, hbar, bad = line_model_law(
            self.state, self.par, self.model.q, self.cal_c, self.cal_u, m["position_m"], m["velocity_m_s"],
            m["acceleration_m_s2"], m["force_N"], m["pressure_valve_1_Pa"], m["pressure_valve_2_Pa"], fd, fd_rate)
        if bad >= 0:
            pc = (pc1, pc2)[bad]
            raise SensorInputError(f"line-model controller stopped at t = {t:.6g} s: its chamber pressure "
                                   f"estimate P_c{bad + 1} = {pc!r} Pa left its range (0, 1e8) Pa")
        return u, (fvd, fv, pc1, pc2, hbar)


#: The parameters of line_model_law as one named record (all float64; passed as its float view,
#: read back with ``par.view(LM_PARAMS)[0]``): sample time, outer gains lambda, k_p1, k_i1, inner
#: k_p2, k_i2, the line-flow damping k_m, per side the chamber dead volume, half the line volume,
#: the inertance A/L and the bore, the viscosity and the F_vd derivative filter's coefficients.
LM_PARAMS = np.dtype([(name, np.float64) for name in (
    "dt", "lam", "kp1", "ki1", "kp2", "ki2", "km", "dead_1", "dead_2", "half_1", "half_2", "inertance_1",
    "inertance_2", "bore_1", "bore_2", "mu", "filter_a", "filter_b")])
#: Its state (float64 record, the same way): the line model's chamber pressures and flows, the
#: previous position, the start phase (0, 1, 2), the integrals w_1, w_2 and the filter's x and y.
LM_STATE = np.dtype([(name, np.float64) for name in (
    "pc_1", "mc_1", "pc_2", "mc_2", "z_prev", "started", "w_1", "w_2", "filter_x", "filter_y")])


@njit(cache=True)
def line_model_law(st, par, q, cal_c, cal_u, z, v, acc, force, pv1, pv2, fd, fd_rate):
    """One sample of :class:`LineModel` (eqs 63-72 with the module's unit corrections), state
    ``st`` (line-model pressures and flows, previous position, integrals w_1 and w_2, the F_vd
    derivative filter) updated in place.  Returns (u, F_vd, F_V, P_c1, P_c2, h_bar, bad) with bad
    the side (0, 1) whose chamber-pressure estimate left (0, 1e8) Pa, else -1."""
    r = st.view(LM_STATE)[0]
    g = par.view(LM_PARAMS)[0]
    p = q.view(MODEL)[0]
    rt, a1, a2 = p.rt, p.area_1, p.area_2
    dt, mu = g.dt, g.mu
    half1, half2 = g.half_1, g.half_2
    vn1 = g.dead_1 + a1 * z + half1
    vn2 = g.dead_2 + a2 * (p.stroke - z) + half2
    if r.started == 0.0:
        r.pc_1, r.mc_1, r.pc_2, r.mc_2 = pv1, 0.0, pv2, 0.0
        fr1 = steady_coefficient(0.0, mu / (pv1 / rt), g.bore_1, 0, mu)
        fr2 = steady_coefficient(0.0, mu / (pv2 / rt), g.bore_2, 0, mu)
        r.started = 1.0
    else:
        zp = r.z_prev
        vo1 = g.dead_1 + a1 * zp + half1
        vo2 = g.dead_2 + a2 * (p.stroke - zp) + half2
        pc, mc, fr1 = line_model_step(r.pc_1, r.mc_1, pv1, (vo1, vn1), dt, g.inertance_1, g.bore_1, mu, rt)
        r.pc_1, r.mc_1 = pc, mc
        if not (math.isfinite(pc) and 0.0 < pc < 1e8):
            return 0.0, 0.0, 0.0, pc, r.pc_2, 0.0, 0
        pc, mc, fr2 = line_model_step(r.pc_2, r.mc_2, pv2, (vo2, vn2), dt, g.inertance_2, g.bore_2, mu, rt)
        r.pc_2, r.mc_2 = pc, mc
        if not (math.isfinite(pc) and 0.0 < pc < 1e8):
            return 0.0, 0.0, 0.0, r.pc_1, pc, 0.0, 1
    r.z_prev = z
    pc1, mc1, pc2, mc2 = r.pc_1, r.mc_1, r.pc_2, r.mc_2
    # eqs 64-65 with the A/L of eq 63: h_bar (1/s)
    inert = 0.5 * (g.inertance_1 + g.inertance_2)
    hbar = inert * rt / (0.5 * (fr1 + fr2) * 0.5 * (vn1 + vn2))
    # F_p of eq 70 from the line model's chamber pressures (section 5.3.1: "chamber pressures
    # are obtained using the line model"), so F_p + P_atm A_rod = P_c1 A1 - P_c2 A2
    g1 = p.viscous * acc + a1 * pc1 * (a1 * v) / vn1 - a2 * pc2 * (-a2 * v) / vn2
    e1 = fd - force
    shift = (fd_rate + g.lam * e1 + g1) / hbar + g.kp1 * e1 + g.ki1 * r.w_1
    km = g.km
    if km > 0:
        # line inertia (section 5.3.1 neglects dm_c/dt): the chamber-flow force rate
        # phi = R T (A1 m_c1 / V1 - A2 m_c2 / V2) obeys phi' = w_L^2 (F_V - F_p) - f phi with
        # w_L^2 = h_bar f; F_vd above asks for phi_d = h_bar * shift in steady flow; the extra
        # term makes phi_d - phi decay at k_m instead of coasting at the friction rate f
        phi = rt * (a1 * mc1 / vn1 - a2 * mc2 / vn2)
        w2l = inert * rt / (0.5 * (vn1 + vn2))
        shift += (km - w2l / hbar) * (hbar * shift - phi) / w2l
    fvd = pc1 * a1 - pc2 * a2 + shift
    fv = pv1 * a1 - pv2 * a2
    e2 = fvd - fv
    # F_vd': the chamber-force part from the line model itself (eq 55, no lag), the rest through
    # the first-order filtered derivative (Tustin, as DifferentiatingFilter)
    chamber_rate = a1 * (mc1 * rt - pc1 * a1 * v) / vn1 - a2 * (mc2 * rt + pc2 * a2 * v) / vn2
    if r.started == 1.0:
        r.filter_x = shift
        r.started = 2.0
    r.filter_y = g.filter_a * r.filter_y + g.filter_b * (shift - r.filter_x)
    r.filter_x = shift
    fvd_rate = chamber_rate + r.filter_y
    # eqs 56, 67, 72 with R T: F_V' = R T (A1 (m_v1 - m_c1) / Vh1 - A2 (m_v2 - m_c2) / Vh2)
    target = (fvd_rate + g.kp2 * e2 + g.ki2 * r.w_2) / rt + a1 * mc1 / half1 - a2 * mc2 / half2
    if target >= 0:
        den = psi(p.p_supply, pv1, p) * a1 / half1 + psi(pv2, p.p_atm, p) * a2 / half2
    else:
        den = psi(pv1, p.p_atm, p) * a1 / half1 + psi(p.p_supply, pv2, p) * a2 / half2
    u = command_for(target / max(den, 1e-300), cal_c, cal_u)
    # anti-windup: integrate unless the command is saturated and the error would push it further
    if abs(u) < 1.0 or (u > 0) != (e1 > 0):
        r.w_1 += e1 * dt
    if abs(u) < 1.0 or (u > 0) != (e2 > 0):
        r.w_2 += e2 * dt
    return u, fvd, fv, pc1, pc2, hbar, -1


def _check_gains(**gains) -> None:
    for name, value in gains.items():
        if not (isinstance(value, (int, float)) and math.isfinite(value) and value >= 0):
            raise SensorInputError(f"controller gain {name} = {value!r}: must be a finite number >= 0")
