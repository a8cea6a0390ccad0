"""Four-way proportional spool valve: ISO 6358 flow (eq 14, Appendix A eqs 88-89).

Mass flow through one orifice is m = C rho0 sqrt(T0/T) P_u * phi(P_d/P_u) with the
corrected ISO 6358 form of DESIGN section 12:

* choked, phi = 1, when P_d / P_u <= b;
* subsonic, phi = sqrt(1 - ((P_d/P_u - b) / (1 - b))^2), for b < P_d / P_u <= r_lam;
* laminar near equal pressures, phi linear in (1 - P_d/P_u) down to zero at P_d = P_u
  (ISO 6358-2:2013 uses r_lam = 0.999), so the flow is continuous, monotonic and finite
  in slope through zero;
* reversed (negative) flow when P_d > P_u.

Each port i of the four-way valve has a supply orifice (supply -> port) and an exhaust
orifice (port -> atmosphere) whose sonic conductances C (m^3/(s Pa)) come from a
calibration table against the normalised command u in [-1, 1].  Port 2 sees the mirrored
command -u, so the net areas satisfy A_v1 A_v2 < 0 (Appendix A): u > 0 charges port 1 and
vents port 2.  An underlapped spool (Festo MPYE) keeps both orifices of a port slightly
open around u = 0 (leakage); an overlapped one (Enfield LH05) closes both.

Spool dynamics: by default the spool follows the command at once.  A finite ``bandwidth_Hz``
makes the spool position a state that lags the command, first order
u_s' = w_b (u - u_s), or second order u_s'' = w_b^2 (u - u_s) - sqrt(2) w_b u_s' (Butterworth
damping), both with their -3 dB point at w_b = 2 pi ``bandwidth_Hz``; the conductances are read
at the spool position.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from numba import njit

from sensor.errors import SensorInputError
from sensor.pneumatic.air import AIR, Air

LAMINAR_RATIO = 0.999  # ISO 6358-2:2013 laminar-region pressure ratio


@njit(cache=True)
def orifice_flow(c, b, r_lam, pu, pd, k_ref):
    """Mass flow (kg/s) from pu to pd through conductance c, and its partials.

    k_ref = rho0 sqrt(T0 / T) (kg/m^3).  Returns (m, dm/dpu, dm/dpd); m < 0 when pd > pu.
    """
    if c <= 0.0:
        return 0.0, 0.0, 0.0
    k = c * k_ref
    if pu >= pd:
        sign, hi, lo = 1.0, pu, pd
    else:
        sign, hi, lo = -1.0, pd, pu
    if hi <= 0.0:
        return 0.0, 0.0, 0.0
    r = lo / hi
    if r <= b:
        m, d_hi, d_lo = k * hi, k, 0.0
    elif r <= r_lam:
        s = (r - b) / (1.0 - b)
        root = math.sqrt(1.0 - s * s)
        dm_dr = -k * hi * s / (root * (1.0 - b))
        m = k * hi * root
        d_lo = dm_dr / hi
        d_hi = k * root - dm_dr * lo / (hi * hi)
    else:
        s = (r_lam - b) / (1.0 - b)
        g = k * math.sqrt(1.0 - s * s) / (1.0 - r_lam)
        m, d_hi, d_lo = g * (hi - lo), g, -g
    if sign > 0.0:
        return m, d_hi, d_lo
    return -m, -d_lo, -d_hi


@njit(cache=True)
def port_flow(u, grid, c_sup, c_exh, b, r_lam, p_supply, p_port, p_atm, k_ref):
    """Net mass flow (kg/s) into a port at command u, and its derivative in p_port."""
    cs = np.interp(u, grid, c_sup)
    ce = np.interp(u, grid, c_exh)
    m_in, _, din_dpd = orifice_flow(cs, b, r_lam, p_supply, p_port, k_ref)
    m_out, dout_dpu, _ = orifice_flow(ce, b, r_lam, p_port, p_atm, k_ref)
    return m_in - m_out, din_dpd - dout_dpu


def _positive(name: str, value: float) -> float:
    if not (math.isfinite(value) and value > 0):
        raise SensorInputError(f"{name} = {value!r}: must be a positive finite number")
    return float(value)



def _check_command(u) -> None:
    """A valve command must be a finite number in [-1, 1] (the spool's full travel)."""
    if not (np.isfinite(u) and -1.0 <= u <= 1.0):
        raise SensorInputError(f"valve command u = {u!r}: must lie in [-1, 1] (full spool travel)")

@dataclass(frozen=True)
class Valve:
    """Calibrated four-way spool valve (port 1 table; port 2 uses the mirrored command).

    command: increasing grid of normalised commands u in [-1, 1];
    supply_conductance / exhaust_conductance: sonic conductance C (m^3/(s Pa)) of port 1's
    supply and exhaust orifices at each grid command; critical_ratio: b;
    laminar_ratio: r_lam of the laminar end.
    """

    name: str
    command: tuple[float, ...]
    supply_conductance: tuple[float, ...]
    exhaust_conductance: tuple[float, ...]
    critical_ratio: float = 0.3
    laminar_ratio: float = LAMINAR_RATIO
    air: Air = field(default=AIR, repr=False)
    bandwidth_Hz: float = math.inf
    spool_order: int = 1

    def __post_init__(self) -> None:
        u = np.asarray(self.command, float)
        if u.ndim != 1 or u.size < 2 or np.any(np.diff(u) <= 0):
            raise SensorInputError(f"valve command grid = {self.command!r}: must be strictly increasing, 2+ points")
        if u[0] < -1 - 1e-12 or u[-1] > 1 + 1e-12:
            raise SensorInputError(f"valve command grid spans [{u[0]}, {u[-1]}]: must lie within [-1, 1]")
        for name in ("supply_conductance", "exhaust_conductance"):
            c = np.asarray(getattr(self, name), float)
            if c.shape != u.shape or not np.all(np.isfinite(c)) or np.any(c < 0):
                raise SensorInputError(f"valve {name}: must be {u.size} finite values >= 0 (m^3/(s Pa))")
        if not 0.0 <= self.critical_ratio < self.laminar_ratio < 1.0:
            raise SensorInputError(
                f"valve critical_ratio = {self.critical_ratio!r}, laminar_ratio = {self.laminar_ratio!r}:"
                " need 0 <= b < r_lam < 1")
        if not (self.bandwidth_Hz > 0 and not math.isnan(self.bandwidth_Hz)):
            raise SensorInputError(f"valve bandwidth_Hz = {self.bandwidth_Hz!r}: must be > 0 (inf: ideal spool)")
        if self.spool_order not in (1, 2):
            raise SensorInputError(f"valve spool_order = {self.spool_order!r}: must be 1 or 2")

    def spool_step_matrices(self, h_s: float) -> tuple[float, float, float, float]:
        """Exact one-step map (a00, a01, a10, a11) of the spool error (u_s - u, u_s') over h_s
        seconds with the command held: the matrix exponential of the spool dynamics."""
        from scipy.linalg import expm

        w = 2.0 * math.pi * self.bandwidth_Hz
        if self.spool_order == 1:
            return math.exp(-w * h_s), 0.0, 0.0, 0.0
        a = expm(np.array([[0.0, 1.0], [-w * w, -math.sqrt(2.0) * w]]) * h_s)
        return float(a[0, 0]), float(a[0, 1]), float(a[1, 0]), float(a[1, 1])

    @property
    def k_ref(self) -> float:
        """rho0 sqrt(T0/T) in kg/m^3 (eq 88)."""
        return self.air.rho0_kg_m3 * math.sqrt(self.air.t0_K / self.air.temperature_K)

    def arrays(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(grid, supply C, exhaust C) as float arrays for the compiled plant."""
        return (np.asarray(self.command, float), np.asarray(self.supply_conductance, float),
                np.asarray(self.exhaust_conductance, float))

    def conductances(self, u: float, port: int = 1) -> tuple[float, float]:
        """(supply, exhaust) sonic conductance of port 1 or 2 at command u in [-1, 1]."""
        if port not in (1, 2):
            raise SensorInputError(f"valve port = {port!r}: must be 1 or 2")
        _check_command(u)
        grid, cs, ce = self.arrays()
        uu = float(u) * (1.0 if port == 1 else -1.0)
        return float(np.interp(uu, grid, cs)), float(np.interp(uu, grid, ce))

    def mass_flow(self, u: float, supply_Pa: float, port_Pa: float, port: int = 1) -> float:
        """Net mass flow (kg/s) into port 1 or 2 at command u in [-1, 1] and port pressure
        (eqs 14, 88-89)."""
        _check_command(u)
        grid, cs, ce = self.arrays()
        sgn = 1.0 if port == 1 else -1.0
        m, _ = port_flow(sgn * float(u), grid, cs, ce, self.critical_ratio,
                         self.laminar_ratio, float(supply_Pa), float(port_Pa),
                         self.air.atmosphere_Pa, self.k_ref)
        return m

    def orifice(self, conductance: float, upstream_Pa, downstream_Pa) -> np.ndarray:
        """Vectorised orifice mass flow (kg/s) for a given conductance (eq 88 with the laminar end)."""
        pu, pd = np.broadcast_arrays(np.asarray(upstream_Pa, float), np.asarray(downstream_Pa, float))
        out = np.empty(pu.shape)
        for i in np.ndindex(pu.shape):
            out[i] = orifice_flow(conductance, self.critical_ratio, self.laminar_ratio,
                                  pu[i], pd[i], self.k_ref)[0]
        return out

    def command_for_conductance(self, conductance: float) -> float:
        """Smallest command u whose port-1 supply conductance equals ``conductance`` (inverse
        calibration, for controllers that compute a conductance, eq 51)."""
        grid, cs, _ = self.arrays()
        if not (0 <= conductance <= cs.max()):
            raise SensorInputError(f"conductance = {conductance!r}: must lie in [0, {cs.max():.3e}] m^3/(s Pa)")
        c = np.maximum.accumulate(cs)
        i = int(np.searchsorted(c, conductance))
        if i == 0 or c[i] == c[i - 1]:
            return float(grid[i])
        return float(grid[i - 1] + (grid[i] - grid[i - 1]) * (conductance - c[i - 1]) / (c[i] - c[i - 1]))


_U = (-1.0, -0.5, -0.2, -0.1, -0.05, 0.0, 0.05, 0.1, 0.2, 0.5, 1.0)


def _mirror(c: tuple[float, ...]) -> tuple[float, ...]:
    return tuple(reversed(c))


# Festo MPYE-5-1/8-LF-like: ~350 l/min nominal flow -> C ~ 1.4e-8 m^3/(s Pa), b = 0.3;
# underlapped spool: each orifice keeps 1.5 % of full conductance at u = 0 (Appendix A).
_FESTO_SUP = tuple(1.4e-8 * f for f in (0, 0, 0, 0, 0.004, 0.015, 0.06, 0.14, 0.3, 0.65, 1.0))
FESTO_MPYE = Valve("festo-mpye-5-1/8-lf", _U, _FESTO_SUP, _mirror(_FESTO_SUP), critical_ratio=0.3)

# Enfield LH05-like: ~5 SCFM class -> C ~ 3e-9 m^3/(s Pa), b = 0.35; overlapped spool with a
# closed band |u| <= 0.05 (both orifices shut), so only one side is open at a time.
_ENF_SUP = tuple(3.0e-9 * f for f in (0, 0, 0, 0, 0, 0, 0, 0.08, 0.25, 0.62, 1.0))
ENFIELD_LH05 = Valve("enfield-lh05", _U, _ENF_SUP, _mirror(_ENF_SUP), critical_ratio=0.35)

VALVES = {v.name: v for v in (FESTO_MPYE, ENFIELD_LH05)}
