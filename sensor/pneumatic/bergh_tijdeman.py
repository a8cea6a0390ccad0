"""Bergh-Tijdeman (1965) analytic small-signal response of a tube ending in a volume.

For a tube of length L and radius R ending in a closed volume V_j (no further tubes), the
ratio of end to inlet pressure amplitude is

    p_end / p_in = 1 / (cosh(phi L) + (V_j / V_t) (sigma + 1/k) n phi L sinh(phi L))

with phi = (w / a0) sqrt(J0(a) / J2(a)) sqrt(gamma / n), a = j^(3/2) s, the shear wave
number s = R sqrt(rho w / mu), the polytropic factor of the tube gas
n = [1 + ((gamma - 1)/gamma) J2(a sqrt(Pr)) / J0(a sqrt(Pr))]^(-1), V_t = pi R^2 L,
sigma = 0 (rigid end volume) and k the polytropic exponent of the end volume (1 isothermal).
Laminar mean-flow-free conditions are assumed.  ``heat_transfer=False`` sets n = 1 (the
isothermal tube), the reference for a strictly isothermal line model.
"""
from __future__ import annotations

import numpy as np
from scipy.special import jv

from sensor.pneumatic.air import AIR, Air


def bergh_tijdeman(frequency_Hz, length_m: float, bore_m: float, end_volume_m3: float,
                   mean_pressure_Pa: float, air: Air = AIR, end_polytropic: float = 1.0,
                   heat_transfer: bool = True) -> np.ndarray:
    """Complex p_end / p_in at each frequency (Hz > 0)."""
    f = np.asarray(frequency_Hz, float)
    w = 2.0 * np.pi * f
    rho = air.density(mean_pressure_Pa)
    a0 = air.speed_of_sound
    s = 0.5 * bore_m * np.sqrt(rho * w / air.viscosity_Pa_s)
    alpha = (1j) ** 1.5 * s
    if heat_transfer:
        x = alpha * np.sqrt(air.prandtl)
        n = 1.0 / (1.0 + (air.gamma - 1.0) / air.gamma * jv(2, x) / jv(0, x))
    else:
        n = np.ones_like(alpha)
    phi = (w / a0) * np.sqrt(jv(0, alpha) / jv(2, alpha)) * np.sqrt(air.gamma / n)
    v_tube = np.pi * bore_m**2 / 4.0 * length_m
    pl = phi * length_m
    return 1.0 / (np.cosh(pl) + end_volume_m3 / v_tube / end_polytropic * n * pl * np.sinh(pl))
