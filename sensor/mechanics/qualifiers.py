"""The qualifiers of one solved design: what a designer compares bodies by.

At the target output travel x_out (the optics' working travel, default 1 mm) the input force
is the body's full-scale force, its ``range_N``; sensitivity x_out / range and range are one
number (DESIGN section 13). Hysteresis comes from a strain-energy law (section 6.2.5 of the
thesis, :class:`~sensor.mechanics.hysteresis.StrainEnergyLaw`) and quality = sensitivity / H
is the thesis' Table 6 "SNR".
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields

from sensor.mechanics.hysteresis import DEFAULT_LAW, StrainEnergyLaw, quality
from sensor.mechanics.solver import SolveResult


@dataclass(frozen=True)
class Qualifiers:
    """The qualifiers of one body at its solved state (mm, N, mJ)."""

    amplification: float            # A = output travel / input travel
    k_out_N_per_mm: float           # input force / output travel
    sensitivity_mm_per_N: float     # output travel / input force (1 / k_out)
    strain_energy_mJ: float         # SE stored at the solved state
    hysteresis: float               # predicted H (fraction of full scale) from the law
    quality_mm_per_N: float         # sensitivity / H (Table 6 "SNR")
    range_N: float                  # input force at the solved output travel (full scale)

    @classmethod
    def names(cls) -> tuple[str, ...]:
        return tuple(f.name for f in fields(cls))

    @classmethod
    def missing(cls) -> "Qualifiers":
        """Every qualifier NaN: a body that could not be solved."""
        return cls(*(math.nan for _ in fields(cls)))


def qualify(result: SolveResult, law: StrainEnergyLaw = DEFAULT_LAW) -> Qualifiers:
    """The qualifiers of a solve result under a hysteresis law."""
    h = float(law.predict(result.strain_energy_mJ))
    return Qualifiers(
        amplification=float(result.amplification),
        k_out_N_per_mm=float(result.k_out_N_per_mm),
        sensitivity_mm_per_N=float(result.sensitivity_mm_per_N),
        strain_energy_mJ=float(result.strain_energy_mJ),
        hysteresis=h,
        quality_mm_per_N=float(quality(result.sensitivity_mm_per_N, h)),
        range_N=float(result.input_force_N),
    )
