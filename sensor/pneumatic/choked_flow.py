"""Steady flow through a tube from a reservoir into a back pressure: the analytic references the
distributed line's steady discharge is checked against (``dacm line``, tests).

Both enter the tube isentropically from the reservoir's stagnation state (p0, T0) and carry
Darcy friction f(Re) (laminar 64/Re, Blasius 0.316 Re^-0.25 from Re 4000, linear between 2300 and
4000; Re = G D / mu is constant along the tube for a constant viscosity):

* :func:`isothermal_flow` - isothermal flow with friction at T0 (the plant line's assumption; its
  entrance uses the face Mach at T0): p1^2 - p2^2 = G^2 R T (f L/D + 2 ln(p1/p2)); it chokes at
  the exit Mach 1/sqrt(gamma), p2 = G sqrt(R T) (Shapiro 1953, ch. 6.5).
* :func:`fanno_flow` - adiabatic flow with friction (Fanno): f L/D = fL*(M1) - fL*(M2),
  fL*(M) = (1 - M^2)/(gamma M^2) + (gamma + 1)/(2 gamma) ln((gamma + 1) M^2 / (2 + (gamma - 1) M^2)),
  p/p* = (1/M) sqrt((gamma + 1)/(2 + (gamma - 1) M^2)); it chokes at M2 = 1 (Shapiro ch. 6.3).

Each returns the mass flow (kg/s) and whether the exit chokes (its pressure above the back
pressure).  Roots by scipy's brentq.
"""
from __future__ import annotations

import math

from scipy.optimize import brentq

from sensor.pneumatic.air import AIR, Air


def darcy_friction(reynolds: float) -> float:
    """Darcy friction factor: 64/Re below 2300, Blasius 0.316 Re^-0.25 above 4000, linear between."""
    lam, turb = 64.0 / max(reynolds, 1e-12), 0.316 * max(reynolds, 1e-12) ** -0.25
    if reynolds <= 2300.0:
        return lam
    if reynolds >= 4000.0:
        return turb
    t4000 = 0.316 * 4000.0**-0.25
    return lam + (t4000 - lam) * (reynolds - 2300.0) / 1700.0


def _friction(m: float, bore_m: float, air: Air) -> float:
    return darcy_friction(air.reynolds(m, bore_m))


def isothermal_flow(p0_Pa: float, p_back_Pa: float, length_m: float, bore_m: float,
                    air: Air = AIR) -> tuple[float, bool]:
    """(mass flow kg/s, choked) of isothermal frictional flow with an isentropic entrance."""
    g, rt = air.gamma, air.rt
    area = math.pi * bore_m**2 / 4
    k = g / (g - 1)

    def inlet(m):   # static inlet pressure from p0 (face Mach at T0)
        gg = m / area
        return brentq(lambda p: p * (1 + (g - 1) / 2 * gg * gg * rt / (g * p * p)) ** k - p0_Pa,
                      gg * math.sqrt(rt), p0_Pa)

    def residual(m):
        p1 = inlet(m)
        p2 = max(p_back_Pa, m * math.sqrt(rt) / area)
        return p1**2 - p2**2 - (m / area) ** 2 * rt * (_friction(m, bore_m, air) * length_m / bore_m
                                                        + 2 * math.log(p1 / p2))
    m_top = p0_Pa * area / (math.sqrt(rt) * (1 + (g - 1) / (2 * g)) ** k) * (1 - 1e-9)   # entrance choke
    m = brentq(residual, 1e-12, m_top, xtol=1e-15, rtol=1e-12)
    return m, m * math.sqrt(rt) / area > p_back_Pa


def _flstar(mach: float, g: float) -> float:
    return (1 - mach**2) / (g * mach**2) + (g + 1) / (2 * g) * math.log((g + 1) * mach**2 / (2 + (g - 1) * mach**2))


def _fl_between(m1: float, m2: float, g: float) -> float:
    """fL*(M1) - fL*(M2), written without the cancellation of two large values at low Mach."""
    return ((m2 * m2 - m1 * m1) / (g * m1 * m1 * m2 * m2)
            + (g + 1) / (2 * g) * math.log(m1 * m1 * (2 + (g - 1) * m2 * m2) / (m2 * m2 * (2 + (g - 1) * m1 * m1))))


def _p_over_pstar(mach: float, g: float) -> float:
    return math.sqrt((g + 1) / (2 + (g - 1) * mach**2)) / mach


def fanno_flow(p0_Pa: float, p_back_Pa: float, length_m: float, bore_m: float,
               air: Air = AIR) -> tuple[float, bool]:
    """(mass flow kg/s, choked) of adiabatic frictional (Fanno) flow with an isentropic entrance."""
    g, r_gas, t0 = air.gamma, air.gas_constant_J_kgK, air.temperature_K
    area = math.pi * bore_m**2 / 4

    def state(m1):
        p1 = p0_Pa * (1 + (g - 1) / 2 * m1**2) ** (-g / (g - 1))
        t1 = t0 / (1 + (g - 1) / 2 * m1**2)
        flow = area * p1 * m1 * math.sqrt(g / (r_gas * t1))
        return flow, p1 / _p_over_pstar(m1, g)

    def residual(m1):
        flow, pstar = state(m1)
        if pstar >= p_back_Pa:
            m2 = 1.0
        elif _p_over_pstar(m1, g) * pstar <= p_back_Pa:   # the entrance alone drops below the back pressure
            m2 = m1
        else:
            m2 = brentq(lambda x: _p_over_pstar(x, g) - p_back_Pa / pstar, m1, 1.0)
        return m1 * m1 * (_fl_between(m1, m2, g) - _friction(flow, bore_m, air) * length_m / bore_m)
    m1 = brentq(residual, 1e-6, 1.0 - 1e-9, xtol=1e-14, rtol=1e-12)
    flow, pstar = state(m1)
    return flow, pstar >= p_back_Pa
