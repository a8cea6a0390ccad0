"""Double-acting cylinder, fixed test chambers and environments (eqs 15, 17, 18).

Chamber 1 (cap side, area A1) grows with the piston position z in [0, stroke]; chamber 2
(rod side, A2 = A1 - A_rod) shrinks.  Chamber pressure follows eq 15 with the polytropic
exponent r (1 isothermal, the default, to 1.4 adiabatic), or, with ``wall_conductance_W_K``
set, the energy equation of an ideal gas with wall heat transfer h A (T_w - T) (the chamber
temperature T = P V / (m R) follows from the pressure and the chamber's gas-mass state; h A = 0
is adiabatic, h A -> infinity isothermal).  The piston obeys eqs 17-18 with viscous damping B,
dry friction, laminar leakage across the piston m_leak = k_leak (P1 - P2) and stiff, damped end
stops.  Dry friction: by default Coulomb F_c smoothed as F_c tanh(v / v_s); with ``stiction_N``
> 0 a Karnopp stick-slip model - the piston at rest stays stuck while the applied force is at most
the static friction F_s, and slides against the Stribeck curve F_c + (F_s - F_c) exp(-(v/v_st)^2)
(the thesis measured 0.25 N of stiction on its Airpel cylinder, section 5.4).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

from sensor.errors import SensorInputError


def _check_energy(obj) -> None:
    """The energy-equation switch: None (eq 15) or a wall conductance h A >= 0 with r left at 1."""
    ha = obj.wall_conductance_W_K
    if ha is None:
        return
    if not (math.isfinite(ha) and ha >= 0):
        raise SensorInputError(f"{type(obj).__name__.lower()} wall_conductance_W_K = {ha!r}: must be None "
                               "or a finite number >= 0")
    if obj.polytropic != 1.0:
        raise SensorInputError(f"{type(obj).__name__.lower()} polytropic = {obj.polytropic!r}: must stay 1 "
                               "when wall_conductance_W_K selects the energy equation (which replaces eq 15)")


def _check(obj, names: tuple[str, ...], strict: bool) -> None:
    for name in names:
        value = getattr(obj, name)
        ok = math.isfinite(value) and (value > 0 if strict else value >= 0)
        if not ok:
            rule = "a positive finite number" if strict else "a finite number >= 0"
            raise SensorInputError(f"{type(obj).__name__.lower()} {name} = {value!r}: must be {rule}")


@dataclass(frozen=True)
class Cylinder:
    """Double-acting cylinder (SI units).  Defaults shaped like an Airpel E16 graphite/glass
    cylinder: 16 mm bore, 5 mm rod, 50 mm stroke, light piston, tiny friction, some leakage."""

    bore_m: float = 0.016
    rod_m: float = 0.005
    stroke_m: float = 0.05
    dead_volume_1_m3: float = 1.0e-6
    dead_volume_2_m3: float = 1.0e-6
    piston_mass_kg: float = 0.05
    viscous_N_s_m: float = 2.0
    coulomb_N: float = 0.05
    coulomb_velocity_m_s: float = 1.0e-3
    leak_kg_s_Pa: float = 5.0e-11
    stop_stiffness_N_m: float = 1.0e6
    stop_damping_N_s_m: float = 200.0
    polytropic: float = 1.0
    stiction_N: float = 0.0
    stribeck_velocity_m_s: float = 0.01
    wall_conductance_W_K: float | None = None

    def __post_init__(self) -> None:
        _check(self, ("bore_m", "stroke_m", "dead_volume_1_m3", "dead_volume_2_m3",
                      "piston_mass_kg", "coulomb_velocity_m_s", "stop_stiffness_N_m",
                      "stribeck_velocity_m_s"), True)
        _check(self, ("rod_m", "viscous_N_s_m", "coulomb_N", "leak_kg_s_Pa",
                      "stop_damping_N_s_m", "stiction_N"), False)
        if 0.0 < self.stiction_N < self.coulomb_N:
            raise SensorInputError(f"cylinder stiction_N = {self.stiction_N!r}: must be 0 (no stick-slip) or "
                                   f">= coulomb_N = {self.coulomb_N!r}")
        if self.rod_m >= self.bore_m:
            raise SensorInputError(f"cylinder rod_m = {self.rod_m!r}: must be smaller than bore_m = {self.bore_m!r}")
        if not 1.0 <= self.polytropic <= 1.4:
            raise SensorInputError(f"cylinder polytropic = {self.polytropic!r}: must lie in [1, 1.4] (eq 15)")
        _check_energy(self)

    @property
    def area_1_m2(self) -> float:
        return math.pi * self.bore_m**2 / 4.0

    @property
    def rod_area_m2(self) -> float:
        return math.pi * self.rod_m**2 / 4.0

    @property
    def area_2_m2(self) -> float:
        return self.area_1_m2 - self.rod_area_m2

    def volumes(self, z_m: float) -> tuple[float, float]:
        """Chamber volumes (m^3) at piston position z."""
        return (self.dead_volume_1_m3 + self.area_1_m2 * z_m,
                self.dead_volume_2_m3 + self.area_2_m2 * (self.stroke_m - z_m))

    def force(self, p1_Pa: float, p2_Pa: float, atmosphere_Pa: float) -> float:
        """Actuator force F_p = P1 A1 - P2 A2 - P_atm A_rod in N (eq 17)."""
        return p1_Pa * self.area_1_m2 - p2_Pa * self.area_2_m2 - atmosphere_Pa * self.rod_area_m2


@dataclass(frozen=True)
class FixedChambers:
    """Two rigid chambers (the fixed-volume tests of chapter III, Figures 4-7 and 10)."""

    volume_1_m3: float = 4.5e-5
    volume_2_m3: float = 4.5e-5
    polytropic: float = 1.0
    wall_conductance_W_K: float | None = None

    def __post_init__(self) -> None:
        _check(self, ("volume_1_m3", "volume_2_m3"), True)
        if not 1.0 <= self.polytropic <= 1.4:
            raise SensorInputError(f"fixedchambers polytropic = {self.polytropic!r}: must lie in [1, 1.4] (eq 15)")
        _check_energy(self)


@dataclass(frozen=True)
class Environment:
    """What the rod pushes on.  ``attached=False``: a spring (stiffness, damping) touched when
    z > contact_m, pushing back only (F_e >= 0).  ``attached=True``: a mass-spring-damper fixed to
    the rod, F_e = k (z - contact_m) + b z' + m z''.  ``mass_kg`` only counts when attached."""

    stiffness_N_m: float = 0.0
    damping_N_s_m: float = 0.0
    mass_kg: float = 0.0
    contact_m: float = 0.0
    attached: bool = False

    def __post_init__(self) -> None:
        _check(self, ("stiffness_N_m", "damping_N_s_m", "mass_kg", "contact_m"), False)


def spring_contact(stiffness_N_m: float, contact_m: float = 0.0, damping_N_s_m: float = 0.0) -> Environment:
    """A spring the rod presses once z exceeds ``contact_m``."""
    return Environment(stiffness_N_m, damping_N_s_m, 0.0, contact_m, False)


def mass_spring_damper(mass_kg: float, stiffness_N_m: float, damping_N_s_m: float,
                       rest_m: float = 0.0) -> Environment:
    """A mass-spring-damper load fixed to the rod, spring relaxed at z = ``rest_m``."""
    return Environment(stiffness_N_m, damping_N_s_m, mass_kg, rest_m, True)
