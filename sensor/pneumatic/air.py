"""Air properties and the reference state of the pneumatic plant (SI units).

Every pneumatic module takes its gas constants from one :class:`Air` instance, so a
change of temperature or atmosphere is made in one place.  Values are for dry air at
20 degC: R = 287.05 J/(kg K), gamma = 1.4, mu = 1.81e-5 Pa s, Pr = 0.71.  The ISO 6358
reference state (T0 = 293.15 K, rho0 = 1.185 kg/m^3 at 1 bar) is used by the valve
(Appendix A, eq 88).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

from sensor.errors import SensorInputError


@dataclass(frozen=True)
class Air:
    """Gas constants and ambient state.

    gas_constant_J_kgK: specific gas constant R; gamma: ratio of specific heats k;
    viscosity_Pa_s: dynamic viscosity mu; prandtl: Prandtl number (heat transfer in
    the lines); temperature_K: line and chamber temperature T (isothermal lines,
    chapter III); atmosphere_Pa: ambient pressure; rho0_kg_m3 and t0_K: ISO 6358
    reference density and temperature.
    """

    gas_constant_J_kgK: float = 287.05
    gamma: float = 1.4
    viscosity_Pa_s: float = 1.81e-5
    prandtl: float = 0.71
    temperature_K: float = 293.15
    atmosphere_Pa: float = 101325.0
    rho0_kg_m3: float = 1.185
    t0_K: float = 293.15

    def __post_init__(self) -> None:
        for name in ("gas_constant_J_kgK", "viscosity_Pa_s", "prandtl", "temperature_K",
                     "atmosphere_Pa", "rho0_kg_m3", "t0_K"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0):
                raise SensorInputError(f"air {name} = {value!r}: must be a positive finite number")
        if not (1.0 < self.gamma <= 5.0 / 3.0):
            raise SensorInputError(f"air gamma = {self.gamma!r}: must lie in (1, 5/3]")

    @property
    def rt(self) -> float:
        """R T in J/kg (= m^2/s^2)."""
        return self.gas_constant_J_kgK * self.temperature_K

    def density(self, pressure_Pa: float) -> float:
        """Ideal-gas density rho = P / (R T) in kg/m^3 (eq 11)."""
        return pressure_Pa / self.rt

    @property
    def speed_of_sound(self) -> float:
        """Adiabatic speed of sound c = sqrt(gamma R T) in m/s (the c of eq 4)."""
        return math.sqrt(self.gamma * self.rt)

    def reynolds(self, mass_flow_kg_s: float, bore_m: float) -> float:
        """Pipe Reynolds number Re = 4 |m_dot| / (pi D mu)."""
        return 4.0 * abs(mass_flow_kg_s) / (math.pi * bore_m * self.viscosity_Pa_s)


AIR = Air()
