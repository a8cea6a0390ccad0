"""Transmission-line models behind one interface (chapters III and V).

Every model is a frozen dataclass with ``length_m`` and ``bore_m`` and a :meth:`layout`
that describes it to the compiled plant as pressure nodes (volumes) joined by inertial flow
elements, the last node being merged with the actuator chamber:

* :class:`DeadVolume` - eq 16: one node, the line volume added to the chamber; the valve
  port pressure equals the chamber pressure.
* :class:`RicherHurmuzlu` - eqs 4-5: one node as above, but the chamber receives the valve
  flow delayed by L / c and attenuated by exp(-R_t R T L / (2 P c)) (R_t laminar or turbulent,
  eq 5).  The attenuation removes mass (a property of the model, not of the physics).
* :class:`TwoVolume` - eqs 54-58: two nodes (half the line at the valve, half merged with the
  chamber) and one inertial flow with the average friction of eq 57 and density of eq 58.
* :class:`Preliminary` - eqs 7-13, the thesis' preliminary model (section 3.3.2): the line is an
  isothermal intermediate volume in series with the chamber, joined by a steady (inertia-free)
  resistive flow m_f = a (P_line - P_chamber), a = rho A / (L R_t) (eq 10), with rho from the
  valve-port pressure (eq 11) and R_t of eq 5 at the Reynolds number of the valve flow.
* :class:`Distributed` - N segments: N + 1 nodes (half-segment volumes at both ends) and N
  flows with convective momentum (donor cell), choking at the tube ends (isothermal: the face
  velocity cannot pass sqrt(R T), Mach 1 / sqrt(gamma)) and a stop beyond Mach 1, where the
  model (no shocks, isothermal gas) leaves its range.  Steady friction is Hagen-Poiseuille below Re = 2300, Blasius above Re = 4000 and
  linearly blended between; frequency-dependent (unsteady laminar) friction and wall heat
  transfer use the fitted exponential kernels of :mod:`sensor.pneumatic.unsteady`, so the gas
  is isothermal for steady and slow flow and tends to adiabatic at high frequency.  With both
  switched off it is the plain isothermal, steady-friction segmented line.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from sensor.errors import SensorInputError

LAW_EQ57 = 0      # (32 + 0.158 Re^0.75) mu / (rho D^2), eq 57
LAW_BLEND = 1     # Hagen-Poiseuille / blend / Blasius
LAW_RESISTIVE = 2  # eq 10: steady resistive flow, no inertia (the preliminary model)
MACH_LIMIT = 1.0  # the distributed line stops beyond this element Mach number


@dataclass(frozen=True)
class LineLayout:
    """How the compiled plant sees a line (all SI)."""

    node_volumes_m3: tuple[float, ...]
    inertance_m: float          # A / dx, the factor on the pressure difference in eq 54
    bore_m: float
    area_m2: float
    length_m: float
    friction_law: int
    unsteady_friction: bool
    heat_transfer: bool
    delay_s: float
    attenuation: bool
    convective: bool = False
    mach_limit: float = math.inf


MAX_LENGTH_M = 1000.0   # longer lines are beyond any tele-operated rig (and the step tests' time bound)
MAX_BORE_M = 1.0
MAX_SEGMENTS = 1000     # the substep shrinks and the state grows with the segment count


def _check_geometry(length_m: float, bore_m: float, allow_zero_length: bool = False) -> None:
    ok_len = math.isfinite(length_m) and (length_m >= 0 if allow_zero_length else length_m > 0)
    if not (ok_len and length_m <= MAX_LENGTH_M):
        rule = ">= 0" if allow_zero_length else "> 0"
        raise SensorInputError(f"line length_m = {length_m!r}: must be a finite number {rule} and <= "
                               f"{MAX_LENGTH_M:g} m")
    if not (math.isfinite(bore_m) and 0 < bore_m <= MAX_BORE_M):
        raise SensorInputError(f"line bore_m = {bore_m!r}: must be a positive finite number <= {MAX_BORE_M:g} m")


@dataclass(frozen=True)
class DeadVolume:
    """Line as a dead volume added to the chamber (eq 16)."""

    length_m: float
    bore_m: float = 0.004

    def __post_init__(self) -> None:
        _check_geometry(self.length_m, self.bore_m, allow_zero_length=True)

    @property
    def area_m2(self) -> float:
        return math.pi * self.bore_m**2 / 4.0

    @property
    def volume_m3(self) -> float:
        return self.area_m2 * self.length_m

    def layout(self) -> LineLayout:
        return LineLayout((self.volume_m3,), 0.0, self.bore_m, self.area_m2, self.length_m,
                          LAW_EQ57, False, False, 0.0, False)


@dataclass(frozen=True)
class RicherHurmuzlu(DeadVolume):
    """Delay L / c and attenuation of the chamber mass flow (eqs 4-5)."""

    def delay_s(self, speed_of_sound_m_s: float) -> float:
        """Pure delay L / c (s)."""
        return self.length_m / speed_of_sound_m_s

    def layout(self) -> LineLayout:
        return LineLayout((self.volume_m3,), 0.0, self.bore_m, self.area_m2, self.length_m,
                          LAW_EQ57, False, False, float("nan"), True)


def tube_resistance(mass_flow_kg_s, bore_m: float, viscosity_Pa_s: float):
    """R_t of eq 5 in kg/(m^3 s): 32 mu / D^2 if Re <= 2300, else 0.158 mu Re^0.75 / D^2."""
    re = 4.0 * np.abs(np.asarray(mass_flow_kg_s, float)) / (math.pi * bore_m * viscosity_Pa_s)
    return np.where(re <= 2300.0, 32.0, 0.158 * re**0.75) * viscosity_Pa_s / bore_m**2


def attenuation_factor(mass_flow_kg_s, length_m: float, bore_m: float, pressure_Pa, air) -> np.ndarray:
    """exp(-R_t R T L / (2 P c)) of eq 4."""
    rt = tube_resistance(mass_flow_kg_s, bore_m, air.viscosity_Pa_s)
    return np.exp(-rt * air.rt * length_m / (2.0 * np.asarray(pressure_Pa, float) * air.speed_of_sound))


@dataclass(frozen=True)
class TwoVolume(DeadVolume):
    """Two control volumes and one inertial flow with the average friction of eq 57."""

    def __post_init__(self) -> None:
        _check_geometry(self.length_m, self.bore_m)

    def layout(self) -> LineLayout:
        half = self.volume_m3 / 2.0
        return LineLayout((half, half), self.area_m2 / self.length_m, self.bore_m, self.area_m2,
                          self.length_m, LAW_EQ57, False, False, 0.0, False)


@dataclass(frozen=True)
class Preliminary(TwoVolume):
    """The thesis' preliminary model (eqs 7-13): line volume and chamber joined by a steady
    resistive flow a (P_line - P_chamber), a = rho A / (L R_t) from the valve-port pressure."""

    def layout(self) -> LineLayout:
        return LineLayout((self.volume_m3, 0.0), 0.0, self.bore_m, self.area_m2, self.length_m,
                          LAW_RESISTIVE, False, False, 0.0, False)


@dataclass(frozen=True)
class Distributed(DeadVolume):
    """N-segment line with frequency-dependent friction and heat transfer (high fidelity).

    convective: momentum flux and choking (False gives the acoustic line of earlier versions)."""

    segments: int = 20
    unsteady_friction: bool = True
    heat_transfer: bool = True
    convective: bool = True

    def __post_init__(self) -> None:
        _check_geometry(self.length_m, self.bore_m)
        if not isinstance(self.segments, (int, np.integer)) or not 1 <= self.segments <= MAX_SEGMENTS:
            raise SensorInputError(f"line segments = {self.segments!r}: must be an integer in [1, {MAX_SEGMENTS}]")

    def layout(self) -> LineLayout:
        n = int(self.segments)
        seg = self.volume_m3 / n
        vols = (seg / 2.0,) + (seg,) * (n - 1) + (seg / 2.0,)
        return LineLayout(vols, self.area_m2 * n / self.length_m, self.bore_m, self.area_m2,
                          self.length_m, LAW_BLEND, self.unsteady_friction, self.heat_transfer,
                          0.0, False, self.convective, MACH_LIMIT)


LINE_MODELS = {"dead-volume": DeadVolume, "richer-hurmuzlu": RicherHurmuzlu, "preliminary": Preliminary,
               "two-volume": TwoVolume, "distributed": Distributed}
"""Every line model by its name: the one list the CLI, the analysis and the plots use."""


def make_line(model: str, length_m: float, bore_m: float = 0.004, **options):
    """Build a line model by its name in :data:`LINE_MODELS`."""
    if model not in LINE_MODELS:
        raise SensorInputError(f"line model = {model!r}: must be one of {', '.join(LINE_MODELS)}")
    return LINE_MODELS[model](length_m, bore_m, **options)
