"""Frequency-dependent wall friction and heat transfer of laminar tube flow.

Small-signal laminar flow in a tube of radius R has the exact (Womersley / Bergh-Tijdeman)
series impedance and shunt admittance per unit length

    Z = (j w rho / A) / (1 - G(s)),          Y = (j w A / (rho a0^2)) (1 + (gamma - 1) G(s sqrt(Pr)))

with G(s) = 2 J1(a) / (a J0(a)), a = j^(3/2) s, and the shear wave number s = R sqrt(w / nu).
With the dimensionless frequency w_hat = s^2 = w R^2 / nu the two kernels are approximated by
sums of first-order relaxations with fixed log-spaced poles n_i:

* friction (Zielke's weighting function as a sum of exponentials, the Trikha / Schohl idea):
  1 / (1 - G) ~= 1 + 8 / (j w_hat) + 4 sum_i m_i / (j w_hat + n_i); in the time domain the
  wall friction on the mass flow is (32 nu / D^2) m_dot + (16 nu / D^2) sum_i m_i y_i with
  y_i' = m_dot' - (4 nu n_i / D^2) y_i;
* heat transfer: G(x) ~= sum_i a_i n_i / (j w_hat_T + n_i), w_hat_T = Pr w_hat, sum a_i = 1;
  in the time domain the wall heat exchange makes a tube node's compressibility move from
  isothermal (slow changes) to adiabatic (fast changes).

The weights are fitted once by non-negative least squares to the exact Bessel-function
kernels over w_hat in [1e-2, 1e5]; :func:`kernel_errors` reports the fit's worst relative
error (below 1 % for the default 8 poles).  This choice (a fitted exponential sum rather than
a published coefficient set) keeps the same machinery for friction and heat transfer, stays
accurate up to the segment cut-off frequency of any practical line, and needs only linear
relaxation states that the stepper integrates exactly.
"""
from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import numpy as np
from scipy.optimize import nnls
from scipy.special import jv

FIT_RANGE = (1e-2, 1e5)


def womersley_g(w_hat: np.ndarray) -> np.ndarray:
    """G = 2 J1(a) / (a J0(a)) with a = j^(3/2) sqrt(w_hat) (exact laminar kernel)."""
    a = (1j) ** 1.5 * np.sqrt(np.asarray(w_hat, float))
    return 2.0 * jv(1, a) / (a * jv(0, a))


@dataclass(frozen=True)
class Kernels:
    """Fitted relaxation weights on the dimensionless poles ``poles`` (see module docstring)."""

    poles: tuple[float, ...]
    friction_weights: tuple[float, ...]
    thermal_weights: tuple[float, ...]


@lru_cache(maxsize=4)
def fitted_kernels(n_poles: int = 8) -> Kernels:
    """Fit the friction and heat-transfer weights on ``n_poles`` log-spaced poles in [1, 1e6]."""
    w = np.logspace(np.log10(FIT_RANGE[0]), np.log10(FIT_RANGE[1]), 400)
    n = np.logspace(0.0, 6.0, n_poles)
    g = womersley_g(w)
    basis = 1.0 / (1j * w[:, None] + n[None, :])
    exact_z = 1.0 / (1.0 - g)
    weight = 1.0 / np.abs(exact_z)
    target = (exact_z - 1.0 - 8.0 / (1j * w)) * weight
    a_mat = 4.0 * basis * weight[:, None]
    m, _ = nnls(np.vstack([a_mat.real, a_mat.imag]), np.concatenate([target.real, target.imag]))
    b_mat = basis * n[None, :]
    a, _ = nnls(np.vstack([b_mat.real, b_mat.imag]), np.concatenate([g.real, g.imag]))
    a = a / a.sum()  # enforce the exact isothermal limit G(0) = 1
    return Kernels(tuple(n), tuple(m), tuple(a))


def friction_factor(w_hat: np.ndarray, kernels: Kernels) -> np.ndarray:
    """Approximate 1 / (1 - G): series-impedance factor over the inviscid j w rho / A."""
    w = np.asarray(w_hat, float)
    n, m = np.asarray(kernels.poles), np.asarray(kernels.friction_weights)
    return 1.0 + 8.0 / (1j * w) + 4.0 * (m[None, :] / (1j * w[:, None] + n[None, :])).sum(axis=1)


def thermal_g(w_hat_t: np.ndarray, kernels: Kernels) -> np.ndarray:
    """Approximate G(x) of the heat-transfer kernel at w_hat_T = Pr w_hat."""
    w = np.asarray(w_hat_t, float)
    n, a = np.asarray(kernels.poles), np.asarray(kernels.thermal_weights)
    return (a[None, :] * n[None, :] / (1j * w[:, None] + n[None, :])).sum(axis=1)


def kernel_errors(kernels: Kernels, gamma: float = 1.4) -> tuple[float, float]:
    """Worst relative error of (series impedance, shunt admittance) against the exact kernels."""
    w = np.logspace(np.log10(FIT_RANGE[0]), np.log10(FIT_RANGE[1]), 997)
    ez = np.max(np.abs(friction_factor(w, kernels) * (1.0 - womersley_g(w)) - 1.0))
    exact_y = 1.0 + (gamma - 1.0) * womersley_g(w)
    ey = np.max(np.abs((1.0 + (gamma - 1.0) * thermal_g(w, kernels)) / exact_y - 1.0))
    return float(ez), float(ey)
