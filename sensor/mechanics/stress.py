"""Hinge stresses from a beam-model solve, and the stress feasibility rule (DESIGN section 14).

Each hinge is a short beam of in-plane thickness t and depth b (the sheet). From the member
end forces of a :class:`~sensor.mechanics.solver.SolveResult` (axial force N, end moments
M_a, M_b: the forces conjugate to the chord-frame deformations, eqs 80-82) the bending
moment varies linearly along the member, M(s) = -M_a + (M_a + M_b) s / L, and the nominal
stress at a station is

    sigma(s) = |N| / (t b) + 6 |M(s)| / (b t^2)        (axial plus bending, MPa)

The beam model clamps each hinge ``ROOT_DEPTH_PER_THICKNESS * t`` inside the bodies it joins
(:mod:`geometry.topology`), so the drawn neck's roots are at that depth from the member's
ends; the nominal stress is evaluated there. The peak at a root is the nominal stress times
the root's stress concentration factor :data:`ROOT_KT`: the drawn profile's roots are sharp
re-entrant corners (unbounded stress in linear elasticity), a cut part's roots carry the
jet's radius r = kerf / 2, and the factor is measured on such roots with the continuum FE.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from geometry.params import Design
from geometry.topology import ROOT_DEPTH_PER_THICKNESS, BeamModel


@dataclass(frozen=True)
class HingeStress:
    """Stresses (MPa) of one hinge at the solved state.

    ``root_nominal_MPa``: axial plus bending at the more loaded neck root; ``neck_MPa``: the
    same one thickness inside the neck from either root (the larger); ``kt``: the root's
    stress concentration factor; ``peak_MPa`` = kt x root_nominal_MPa.
    """

    hinge: int
    root_nominal_MPa: float
    neck_MPa: float
    kt: float
    peak_MPa: float


#: Peak stress at a cut hinge root over the beam's nominal root stress (axial plus bending):
#: the continuum FE of the profiles of samples A and B with the jet's root fillets (r = kerf
#: / 2 = 0.4 mm; 8 quadratic elements across each hinge) gives 1.37-1.55 over all twelve
#: hinges (sample B's 0.3 mm middle hinges 1.37, the 0.5 mm ones 1.41-1.55; with r = 0.2 mm
#: the same within 0.02: the fillet lowers the concentration but shortens the neck); 1.45
#: stands for all within 7 %. The drawn profile's sharp roots have no finite value.
ROOT_KT = 1.45


def _nominal_stress(N, Ma, Mb, t, b, L, s):
    """Axial plus bending stress (MPa) at stations s (mm) of members with end forces N,
    Ma, Mb (arrays, one entry a member): |N| / (t b) + 6 |M(s)| / (b t^2),
    M(s) = -Ma + (Ma + Mb) s / L."""
    return np.abs(N) / (t * b) + 6.0 * np.abs(-Ma + (Ma + Mb) * s / L) / (b * t * t)


def hinge_stresses(model: BeamModel, result,
                   root_depth_per_thickness: float = ROOT_DEPTH_PER_THICKNESS) -> dict[int, HingeStress]:
    """Each hinge's stresses at the solved state of ``result`` (a SolveResult of ``model``)."""
    row = {int(m): i for i, m in enumerate(result.member_index)}
    hinges = model.hinge_members
    N, Ma, Mb = np.asarray(result.member_forces)[[row[int(m)] for m in hinges]].T
    t, b = model.thickness_mm[hinges], model.depth_mm[hinges]
    L = model.lengths_mm[hinges]
    root = root_depth_per_thickness * t
    nominal = np.maximum(_nominal_stress(N, Ma, Mb, t, b, L, root),
                         _nominal_stress(N, Ma, Mb, t, b, L, L - root))
    neck = np.maximum(_nominal_stress(N, Ma, Mb, t, b, L, np.minimum(root + t, L / 2)),
                      _nominal_stress(N, Ma, Mb, t, b, L, np.maximum(L - root - t, L / 2)))
    numbers = model.hinge_number[hinges]
    return {int(h): HingeStress(int(h), float(n), float(k), ROOT_KT, float(ROOT_KT * n))
            for h, n, k in zip(numbers, nominal, neck)}


@dataclass(frozen=True)
class StressCheck:
    """The stress rule for one solved design: ``ok`` when every hinge's peak stress is at
    most the material's allowable stress; ``worst_hinge`` and ``utilisation`` (peak /
    allowable, largest over the hinges) say by how much."""

    ok: bool
    worst_hinge: int
    peak_MPa: float
    allowable_MPa: float
    utilisation: float
    message: str


def stress_check(design: Design, model: BeamModel, result) -> StressCheck:
    """Check every hinge's peak stress at the solved state against
    ``design.material.allowable_stress_MPa``."""
    s = hinge_stresses(model, result)
    worst = max(s.values(), key=lambda h: h.peak_MPa)
    allow = design.material.allowable_stress_MPa
    ratio = worst.peak_MPa / allow
    msg = (f"hinge {worst.hinge}: peak stress {worst.peak_MPa:.1f} MPa (Kt {worst.kt:.2f} x "
           f"{worst.root_nominal_MPa:.1f} MPa nominal) {'<=' if ratio <= 1 else '>'} allowable "
           f"{allow:g} MPa of {design.material.name}")
    return StressCheck(ratio <= 1.0, worst.hinge, worst.peak_MPa, allow, ratio, msg)


def stress_ok(design: Design, model: BeamModel, result) -> bool:
    """Whether every hinge stays within the material's allowable stress (the feasibility
    rule for sweeps and the optimiser)."""
    return stress_check(design, model, result).ok
