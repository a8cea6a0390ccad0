"""Hinge stresses from a beam-model solve, and the stress feasibility rule (DESIGN section 14).

Each hinge is a neck of in-plane thickness t and depth b (the sheet) between two root
fillets (:func:`geometry.topology.hinge_profile`). From the member end forces of a
:class:`~sensor.mechanics.solver.SolveResult` (axial force N, end moments M_a, M_b: the
forces conjugate to the chord-frame deformations, eqs 80-82) the bending moment varies
linearly along the member, M(s) = -M_a + (M_a + M_b) s / L, and the nominal stress at a
station of the neck is

    sigma(s) = |N| / (t b) + 6 |M(s)| / (b t^2)        (axial plus bending, MPa)

The peak stress sits in a root fillet: the nominal stress where the neck meets the fillet
times the fillet's stress concentration factor :func:`root_kt` (a function of r / t fitted
to the continuum FE of cut parts, the form of Peterson's shoulder-fillet factors). The
drawn profile's sharp roots (r = 0) have no finite peak in linear elasticity; they carry
:data:`SHARP_ROOT_KT`, the factor the thesis' specimens' cut roots were once given.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from geometry.params import Design
from geometry.topology import BeamModel


@dataclass(frozen=True)
class HingeStress:
    """Stresses (MPa) of one hinge at the solved state.

    ``root_nominal_MPa``: axial plus bending where the neck meets its more loaded root
    fillet; ``neck_MPa``: the same one thickness inside the neck from either end (the
    larger); ``kt``: that root's stress concentration factor; ``peak_MPa`` = kt x
    root_nominal_MPa (the larger of the two roots').
    """

    hinge: int
    root_nominal_MPa: float
    neck_MPa: float
    kt: float
    peak_MPa: float


#: Kt = 1 + KT_SCALE (t / r)^KT_EXPONENT for a root fillet of radius r on a neck of
#: thickness t in bending (Neuber's form, that of Peterson's shoulder fillets of a flat bar
#: with a tall shoulder): the least-squares fit to the continuum FE's converged peak stress
#: in the fillets of the cut-part entries of tests/mechanics/data/continuum_table.json that
#: are not held out (kerf 0.4-1.2 mm, hinges 0.25-1.5 mm, every hinge carrying at least half
#: its body's largest peak: 83 hinges, RMS 3.2 %, largest 11.9 % on the 1.5 mm hinges);
#: checked within 10 % in tests/mechanics/test_root_rule.py and test_stress.py.
KT_SCALE = 0.24
KT_EXPONENT = 0.63
#: Stress concentration given to a sharp (drawn) root, r = 0.
SHARP_ROOT_KT = 1.45


def root_kt(t_mm, radius_mm):
    """Stress concentration factor of root fillets of radius r (mm) on necks of thickness t
    (mm), arrays broadcast: 1 + KT_SCALE (t / r)^KT_EXPONENT, :data:`SHARP_ROOT_KT` at r = 0."""
    t, r = np.broadcast_arrays(np.asarray(t_mm, dtype=float), np.asarray(radius_mm, dtype=float))
    with np.errstate(divide="ignore"):
        return np.where(r > 0, 1.0 + KT_SCALE * (t / np.where(r > 0, r, 1.0)) ** KT_EXPONENT, SHARP_ROOT_KT)


def _nominal_stress(N, Ma, Mb, t, b, L, s):
    """Axial plus bending stress (MPa) at stations s (mm) of members with end forces N,
    Ma, Mb (arrays, one entry a member): |N| / (t b) + 6 |M(s)| / (b t^2),
    M(s) = -Ma + (Ma + Mb) s / L."""
    return np.abs(N) / (t * b) + 6.0 * np.abs(-Ma + (Ma + Mb) * s / L) / (b * t * t)


def hinge_stresses(model: BeamModel, result) -> dict[int, HingeStress]:
    """Each hinge's stresses at the solved state of ``result`` (a SolveResult of ``model``)."""
    row = {int(m): i for i, m in enumerate(result.member_index)}
    hinges = model.hinge_members
    N, Ma, Mb = np.asarray(result.member_forces)[[row[int(m)] for m in hinges]].T
    t, b = model.thickness_mm[hinges], model.depth_mm[hinges]
    L = model.lengths_mm[hinges]
    s0, s1 = model.neck_mm[hinges].T
    roots = np.stack([_nominal_stress(N, Ma, Mb, t, b, L, s0), _nominal_stress(N, Ma, Mb, t, b, L, s1)])
    kt = root_kt(t[None, :], model.root_radius_mm[hinges].T)
    peaks = kt * roots
    worst = np.argmax(peaks, axis=0)
    cols = np.arange(len(hinges))
    neck = np.maximum(_nominal_stress(N, Ma, Mb, t, b, L, np.minimum(s0 + t, (s0 + s1) / 2)),
                      _nominal_stress(N, Ma, Mb, t, b, L, np.maximum(s1 - t, (s0 + s1) / 2)))
    numbers = model.hinge_number[hinges]
    return {int(h): HingeStress(int(h), float(roots[w, i]), float(k), float(kt[w, i]), float(peaks[w, i]))
            for i, (h, w, k) in enumerate(zip(numbers, worst, neck))}


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
