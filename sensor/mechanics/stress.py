"""Hinge stresses from a beam-model solve, and the stress feasibility rule (DESIGN section 14).

Each hinge is a neck of in-plane thickness t and depth b (the sheet) between two root
fillets (:func:`geometry.topology.hinge_profile`). From the member end forces of a
:class:`~sensor.mechanics.solver.SolveResult` (axial force N, end moments M_a, M_b: the
forces conjugate to the chord-frame deformations, eqs 80-82) the bending moment varies
linearly along the member, M(s) = -M_a + (M_a + M_b) s / L, and the nominal stress at a
station of the neck is

    sigma(s) = |N| / (t b) + 6 |M(s)| / (b t^2)        (axial plus bending, MPa)

on its more loaded face; on each face, N / (t b) -/+ 6 M(s) / (b t^2) (left / right of the
member's axis). The peak stress sits in a root fillet, and each of the four (two ends, two
faces) concentrates its own face's stress where it meets the neck by :func:`root_kt` (a
function of r / t fitted to the continuum FE of cut parts, the form of Peterson's
shoulder-fillet factors). Where a face leans from the hinge's normal, the fillet in its
obtuse corner meets the neck nearer the face, in a section the acute fillet across has
already widened (:func:`fillet_widening_mm`): its face's stress is taken there, in that
widened section, whose centroid lies off the axis so that the axial force bends it too
(the continuum shows such a fillet with no concentration in a bent hinge and the full one
where an axial force leaves the face across unloaded). With an axial force the two faces
differ, and the fillet of the less loaded face can govern. The drawn profile's sharp roots
(r = 0) have no finite peak in linear elasticity; they carry :data:`SHARP_ROOT_KT`, the
factor the thesis' specimens' cut roots were once given.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from geometry.params import Design
from geometry.topology import BeamModel


@dataclass(frozen=True)
class HingeStress:
    """Stresses (MPa) of one hinge at the solved state.

    ``root_nominal_MPa``: the stress of the governing root fillet's face where the neck
    starts; ``neck_MPa``: axial plus bending one thickness inside the neck from either end
    (the larger); ``kt``: the governing fillet's factor; ``peak_MPa`` = kt x
    root_nominal_MPa (the largest of the four fillets').
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
#: its body's largest peak: 221 hinges, RMS 1.9 %; 5.2 % at most on the 361 of all entries);
#: checked within 10 % on every entry in tests/mechanics/test_root_rule.py.
KT_SCALE = 0.232
KT_EXPONENT = 0.825
#: Stress concentration given to a sharp (drawn) root, r = 0.
SHARP_ROOT_KT = 1.45


def root_kt(t_mm, radius_mm):
    """Stress concentration factor of root fillets of radius r (mm) on necks of thickness t
    (mm), arrays broadcast: 1 + KT_SCALE (t / r)^KT_EXPONENT, :data:`SHARP_ROOT_KT` at r = 0."""
    t, r = np.broadcast_arrays(np.asarray(t_mm, dtype=float), np.asarray(radius_mm, dtype=float))
    with np.errstate(divide="ignore"):
        return np.where(r > 0, 1.0 + KT_SCALE * (t / np.where(r > 0, r, 1.0)) ** KT_EXPONENT, SHARP_ROOT_KT)


def _nominal_stress(N, Ma, Mb, t, b, L, s):
    """Axial plus bending stress (MPa) at stations s (mm) on the more loaded face of
    members with end forces N, Ma, Mb (arrays, one entry a member): |N| / (t b) +
    6 |M(s)| / (b t^2) (:func:`_face_stress` of both faces, the larger)."""
    return np.maximum(_face_stress(N, Ma, Mb, t, b, L, s, 1.0), _face_stress(N, Ma, Mb, t, b, L, s, -1.0))


def _face_stress(N, Ma, Mb, t, b, L, s, side, across=0.0):
    """Stress (MPa, magnitude) on one face of members with end forces N, Ma, Mb at stations
    s (mm): the left face (``side`` +1, the member's normal rotated +90 deg from its axis)
    or the right (-1). The section there is t plus ``across`` (mm) wide, widened on the
    other face only, so its centroid sits across / 2 off the member's axis and the axial
    force bends it too: N / (b w) - 6 side M(s) / (b w^2) + 3 N across / (b w^2),
    w = t + across (plane sections; M > 0 compresses the left face)."""
    w = t + across
    M = -Ma + (Ma + Mb) * s / L
    return np.abs(N / (b * w) - side * 6.0 * M / (b * w * w) + 3.0 * N * across / (b * w * w))


def fillet_widening_mm(t_mm, radius_mm, reach_mm):
    """How much the fillet across widens the section where a root fillet meets the neck
    (mm): the fillet across, of radius r, meets the neck ``reach_mm`` further along; its
    height here, r - sqrt(r^2 - reach^2) (r past one radius), counts in proportion to how
    far it has grown, up to one neck thickness (Saint-Venant: added material takes its
    share of the stress over about one thickness). 0 where both fillets meet the neck
    together (a face square to the hinge)."""
    reach = np.clip(reach_mm, 0.0, None)
    gap = np.minimum(reach, radius_mm)
    height = radius_mm - np.sqrt(np.maximum(radius_mm * radius_mm - gap * gap, 0.0))
    return height * np.minimum(1.0, reach / t_mm)


def _hinge_loads(model: BeamModel, result) -> tuple:
    """A solved model's hinges, in hinge-number order: (N, Ma, Mb, t, b, L, s0, s1) (hinge,),
    where the fillets meet the neck (end, side, hinge) and their radii (end, 1, hinge)."""
    row = {int(m): i for i, m in enumerate(result.member_index)}
    hinges = model.hinge_members
    N, Ma, Mb = np.asarray(result.member_forces)[[row[int(m)] for m in hinges]].T
    s0, s1 = model.neck_mm[hinges].T
    return (N, Ma, Mb, model.thickness_mm[hinges], model.depth_mm[hinges], model.lengths_mm[hinges], s0, s1,
            np.moveaxis(model.fillet_neck_mm[hinges], 0, -1), model.root_radius_mm[hinges].T[:, None, :])


def _stresses(N, Ma, Mb, t, b, L, s0, s1, at, r) -> tuple:
    """The stresses of hinges given by :func:`_hinge_loads` (each hinge on its own, so
    several models' hinges can be joined along the last axis): the candidates' nominal
    stresses and factors (8, hinge), the governing candidate and the neck stress (hinge,)."""
    # how much further the fillet across meets the neck (into the neck: + at the start)
    reach = (at[:, ::-1] - at) * np.array([1.0, -1.0])[:, None, None]
    side = np.array([1.0, -1.0])[None, :, None]
    fillet = _face_stress(N, Ma, Mb, t, b, L, at, side, fillet_widening_mm(t, r, reach))
    neck_start = _face_stress(N, Ma, Mb, t, b, L, np.stack([s0, s1])[:, None, :], side)
    kt = np.broadcast_to(root_kt(t, r), fillet.shape)
    # candidates (fillets, then the neck starts' faces) x hinges
    nominal = np.concatenate([fillet.reshape(4, -1), neck_start.reshape(4, -1)])
    factor = np.concatenate([kt.reshape(4, -1), np.ones((4, len(t)))])
    worst = np.argmax(factor * nominal, axis=0)
    neck = np.maximum(_nominal_stress(N, Ma, Mb, t, b, L, np.minimum(s0 + t, (s0 + s1) / 2)),
                      _nominal_stress(N, Ma, Mb, t, b, L, np.maximum(s1 - t, (s0 + s1) / 2)))
    return nominal, factor, worst, neck


def hinge_stresses(model: BeamModel, result) -> dict[int, HingeStress]:
    """Each hinge's stresses at the solved state of ``result`` (a SolveResult of ``model``).

    Each of a hinge's four root fillets (two ends, two faces) concentrates its own face's
    stress where it meets the neck, by :func:`root_kt`: in the section widened by the
    fillet across where that one reaches further (a face leaning from the hinge's normal,
    :func:`fillet_widening_mm`). The faces' stresses where the neck starts count too (with
    no factor: a shielded fillet's face peaks there). The peak is the largest of these."""
    nominal, factor, worst, neck = _stresses(*_hinge_loads(model, result))
    numbers = model.hinge_number[model.hinge_members]
    return {int(h): HingeStress(int(h), float(nominal[w, i]), float(k), float(factor[w, i]),
                                float(factor[w, i] * nominal[w, i]))
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
    return stress_checks([design], [model], [result])[0]


def stress_checks(designs, models, results) -> list[StressCheck]:
    """:func:`stress_check` of each (design, model, result), the hinges of all of them in one
    vectorised pass (a sweep row checks 41)."""
    nominal, factor = _governing(models, results)
    peak = factor * nominal
    checks, start = [], 0
    for design, model in zip(designs, models):
        numbers = model.hinge_number[model.hinge_members]
        i = start + int(np.argmax(peak[start:start + len(numbers)]))   # the first of equal peaks
        hinge = int(numbers[i - start])
        allow = design.material.allowable_stress_MPa
        ratio = float(peak[i]) / allow
        msg = (f"hinge {hinge}: peak stress {peak[i]:.1f} MPa (Kt {factor[i]:.2f} x "
               f"{nominal[i]:.1f} MPa nominal) {'<=' if ratio <= 1 else '>'} allowable "
               f"{allow:g} MPa of {design.material.name}")
        checks.append(StressCheck(ratio <= 1.0, hinge, float(peak[i]), allow, ratio, msg))
        start += len(numbers)
    return checks


def _governing(models, results) -> tuple[np.ndarray, np.ndarray]:
    """The governing nominal stress (MPa) and its factor of every hinge of every (model,
    result), the models' hinges one after another (each in hinge-number order), in one
    vectorised pass."""
    loads = [_hinge_loads(m, r) for m, r in zip(models, results)]
    nominal, factor, worst, _ = _stresses(*(np.concatenate(a, axis=-1) for a in zip(*loads)))
    k = np.arange(len(worst))
    return nominal[worst, k], factor[worst, k]


def peak_stresses(models, results) -> np.ndarray:
    """Each hinge's peak stress (MPa; :func:`hinge_stresses`' ``peak_MPa``) of models with
    the same hinges, solved (``results``): (models, hinges), in hinge-number order."""
    nominal, factor = _governing(models, results)
    return (factor * nominal).reshape(len(models), -1)


def stress_ok(design: Design, model: BeamModel, result) -> bool:
    """Whether every hinge stays within the material's allowable stress (the feasibility
    rule for sweeps and the optimiser)."""
    return stress_check(design, model, result).ok
