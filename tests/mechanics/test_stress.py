"""Hinge stresses from a beam solve and the stress rule (sensor.mechanics.stress)."""

import dataclasses
import math

import numpy as np
import pytest

from geometry.params import MATERIALS, Material, preset
from geometry.topology import BeamModel, build_beam_model
from sensor.mechanics.continuum import verify
from sensor.mechanics.solver import solve
from sensor.mechanics.stress import (SHARP_ROOT_KT, _face_stress, fillet_widening_mm, hinge_stresses, root_kt,
                                     stress_check, stress_ok)


def cantilever(L=3.0, t=0.5, b=5.1, E=2300.0, load_index=1e-4):
    EI = E * b * t**3 / 12
    F = load_index * EI / L**2
    model = BeamModel(nodes=np.array([[0.0, 0.0], [L, 0.0]]), member_nodes=np.array([[0, 1]]),
                      member_kind=("hinge",), thickness_mm=np.array([t]), depth_mm=np.array([b]),
                      hinge_number=np.array([1]), member_name=("hinge 1",),
                      supports=((0, ("x", "y", "rz")),), input_node=1,
                      input_direction=np.array([0.0, -1.0]), output_node=1,
                      output_direction=np.array([0.0, -1.0]), E_MPa=E, nu=0.35)
    return model, F


def test_cantilever_root_and_neck_stress_are_beam_theory():
    """Tip load F on a cantilever: bending stress 6 F (L - s) / (b t^2) at station s (the
    load index 1e-4 keeps the axial force from the slope at 1e-4 of it)."""
    L, t, b = 3.0, 0.5, 5.1
    model, F = cantilever(L, t, b)
    s = hinge_stresses(model, solve(model, target_force_N=F))[1]
    assert s.root_nominal_MPa == pytest.approx(6 * F * L / (b * t * t), rel=1e-3)
    assert s.neck_MPa == pytest.approx(6 * F * (L - t) / (b * t * t), rel=1e-3)
    assert s.peak_MPa == pytest.approx(SHARP_ROOT_KT * s.root_nominal_MPa, rel=1e-12)
    # a neck that starts 0.4 mm from the clamp behind a fillet of radius 0.2 mm: the
    # nominal stress is taken where the neck starts, times that fillet's Kt
    filleted = dataclasses.replace(model, neck_mm=np.array([[0.4, L]]), root_radius_mm=np.array([[0.2, 0.0]]),
                                   fillet_neck_mm=np.array([[[0.4, 0.4], [L, L]]]))
    s2 = hinge_stresses(filleted, solve(model, target_force_N=F))[1]
    assert s2.root_nominal_MPa == pytest.approx(6 * F * (L - 0.4) / (b * t * t), rel=1e-3)
    assert s2.kt == pytest.approx(float(root_kt(t, 0.2)))


@pytest.mark.parametrize("lean", [False, True])
def test_each_fillet_concentrates_its_own_face(lean):
    """A cantilever pulled along and bent at once (tip load F at 45 deg down): at station s
    the top (left) face carries a + m(s), the bottom m(s) - a, a = N / (t b), m(s) =
    6 (F / sqrt 2)(L - s) / (b t^2) (statics and beam theory). Square root: the top fillet
    governs, Kt (a + m(0)). Leaning root (the bottom fillet meets the neck 0.3 mm in, the
    top one at the face, in a section the bottom fillet has widened by h = r x 0.3 / t,
    centroid h / 2 off the axis): the candidates are the top fillet, Kt (N / (b w) +
    6 (F / sqrt 2) L / (b w^2) + 3 N h / (b w^2)), w = t + h; the bottom fillet,
    Kt (m(0.3) - a); and the neck's top face where it starts, a + m(0.3)."""
    L, t, b, r, d = 3.0, 0.5, 5.1, 0.2, 0.3
    model, F = cantilever(L, t, b)
    fillets = [[0.0, d], [L, L]] if lean else [[0.0, 0.0], [L, L]]
    model = dataclasses.replace(model, input_direction=np.array([1.0, -1.0]) / math.sqrt(2),
                                neck_mm=np.array([[d if lean else 0.0, L]]), root_radius_mm=np.array([[r, r]]),
                                fillet_neck_mm=np.array([fillets]))
    s = hinge_stresses(model, solve(model, target_force_N=F))[1]
    P = F / math.sqrt(2)
    a = P / (t * b)
    m = lambda x: 6 * P * (L - x) / (b * t * t)  # noqa: E731
    kt = float(root_kt(t, r))
    if lean:
        h = r * d / t
        w = t + h
        top = P / (b * w) + 6 * P * L / (b * w * w) + 3 * P * h / (b * w * w)
        expected = max(kt * top, kt * (m(d) - a), a + m(d))
    else:
        expected = kt * (a + m(0.0))
    assert s.peak_MPa == pytest.approx(expected, rel=2e-3)


def test_widened_section_under_axial_load():
    """A section widened by h on one face only, pure tension: its centroid sits h / 2 off
    the load's line, so the other face carries N / (b w) (1 + 3 h / w), w = t + h."""
    t, b, h, N = 0.5, 5.0, 0.2, 10.0
    w = t + h
    got = _face_stress(N, 0.0, 0.0, t, b, 3.0, 1.0, 1.0, h)
    assert got == pytest.approx(N / (b * w) * (1 + 3 * h / w), rel=1e-12)


def test_fillet_widening_limits():
    """Nothing where both fillets meet the neck together; the fillet across's height
    r - sqrt(r^2 - reach^2), counted in proportion to reach / t up to one thickness; at
    most r."""
    t, r = 0.5, 0.4
    reach = np.array([0.0, 0.1, 0.3, 0.45, 1.0, 5.0])
    got = fillet_widening_mm(t, r, reach)
    expected = (r - np.sqrt(r * r - np.minimum(reach, r) ** 2)) * np.minimum(1, reach / t)
    assert got == pytest.approx(expected, abs=1e-12)
    assert got[0] == 0.0 and got[-1] == pytest.approx(r) and np.all(np.diff(got) >= 0)


def test_root_kt_limits():
    """Kt falls towards 1 as the fillet grows against the neck (a straight bar has none),
    rises as it sharpens, and a drawn sharp root carries SHARP_ROOT_KT."""
    r = np.array([0.05, 0.1, 0.2, 0.4, 0.8, 1e6])
    kt = root_kt(0.5, r)
    assert np.all(np.diff(kt) < 0) and kt[-1] == pytest.approx(1.0, abs=1e-3)
    assert root_kt(0.5, 0.0) == SHARP_ROOT_KT
    # a function of r / t only (the geometry's one scale-free ratio)
    assert root_kt(1.0, 0.4) == pytest.approx(root_kt(0.5, 0.2), rel=1e-12)


def test_materials_carry_a_sourced_allowable_stress():
    assert MATERIALS["delrin"].allowable_stress_MPa == 36.0
    assert MATERIALS["abs"].allowable_stress_MPa == 20.0
    assert Material("x", 1000.0, 0.3).allowable_stress_MPa == math.inf


def test_stress_rule_on_sample_b():
    """Sample B at 1 mm output: the 0.3 mm middle hinges carry the largest stress; with no
    limit the rule passes, with a limit below the peak it fails and names the hinge."""
    d = preset("sample-b")
    m = build_beam_model(d)
    r = solve(m)
    check = stress_check(d, m, r)
    assert check.worst_hinge in (9, 10, 11, 12)
    assert check.ok == (check.peak_MPa <= 36.0) and stress_ok(d, m, r) == check.ok
    loose = d.replace(material=Material("delrin", 2300.0, 0.35))
    assert stress_ok(loose, m, r)
    tight = d.replace(material=Material("delrin", 2300.0, 0.35, 0.9 * check.peak_MPa))
    c = stress_check(tight, m, r)
    assert not c.ok and c.utilisation == pytest.approx(1 / 0.9)
    assert f"hinge {check.worst_hinge}" in c.message and "allowable" in c.message


@pytest.mark.parametrize("name, kerf", [("sample-a", 0.8), ("sample-b", 0.4)])
def test_root_peak_within_10_percent_of_the_continuum_at_cut_roots(name, kerf):
    """Beam peak (fillet Kt x nominal stress where the neck meets the fillet) against the
    continuum FE's peak von Mises stress at the roots rounded by the jet (r = kerf / 2),
    linear, 6 quadratic elements across each hinge (the peak in a fillet of radius >= 0.2
    mm is within 2 % of the 12-element value there), on every hinge that carries at least
    half the largest stress (the ones the stress rule is about; a lightly loaded hinge
    whose moment barely changes along it has no root peak to speak of)."""
    d = preset(name).replace(kerf_mm=kerf)
    fe = verify(d, mesh=6.0, kerf_mm=kerf)
    m = build_beam_model(d)
    r = solve(m, target_output_mm=1e-3)
    beam = {h: s.peak_MPa * fe.output_travel_mm / r.output_travel_mm for h, s in hinge_stresses(m, r).items()}
    top = max(fe.hinge_stress_MPa.values())
    for h, v in fe.hinge_stress_MPa.items():
        if v >= 0.5 * top:
            assert beam[h] == pytest.approx(v, rel=0.10), f"hinge {h}"
