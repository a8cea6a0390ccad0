"""The root rule's form against a continuum model of one hinge (tests/mechanics/
hinge_substructure.py): a neck between a block, whose face leans gamma, and a link, in
plane stress, against the beam model's hinge member (geometry.topology.root_depth_mm).

The rule's constants are fitted to the bodies of the continuum table
(tests/mechanics/test_root_rule.py); these tests check its form on a reference that no fit
has seen: the rotational compliance of a root grows with t sin(gamma)."""

import numpy as np
import pytest
from scipy.optimize import minimize, minimize_scalar

import geometry.topology as topology
from tests.mechanics.hinge_substructure import E_MPA, LINK_MM, beam_compliance, fe_compliance

NECK_MM = 2.82
#: (t, gamma_deg, r) mm, deg, mm: hinges of 0.3-1.25 mm on faces leaning 0-32.3 deg (the
#: basis family's steepest phi1) with the 0.8 mm jet's fillets, and 0.4 / 1.2 mm jets
SUBSTRUCTURES = ([(t, g, 0.4) for t in (0.3, 0.75, 1.25) for g in (0.0, 15.0, 32.3)]
                 + [(0.75, g, r) for r in (0.2, 0.6) for g in (0.0, 32.3)])


@pytest.fixture(scope="module")
def fe():
    """The FE's compliance (3, 3) of each substructure."""
    return {s: fe_compliance(s[0], NECK_MM, *s[1:]) for s in SUBSTRUCTURES}


def errors_pct(fe, monkeypatch, per_thickness, per_lean, entry=(2, 2)) -> np.ndarray:
    """The beam's compliance against the FE's (percent) on every substructure, with the given
    root-rule constants; ``entry`` of the compliance (default the rotation under a moment)."""
    monkeypatch.setattr(topology, "ROOT_DEPTH_PER_THICKNESS", float(per_thickness))
    monkeypatch.setattr(topology, "ROOT_DEPTH_PER_LEAN", float(per_lean))
    topology.hinge_profile.cache_clear()
    errors = [100 * (beam_compliance(s[0], NECK_MM, *s[1:])[entry] / c[entry] - 1) for s, c in fe.items()]
    topology.hinge_profile.cache_clear()
    return np.array(errors)


def test_fe_reference_is_exact_on_the_uniform_link():
    """Two more millimetres of the 2 mm link add exactly 2 / (E A) axially and 2 / (E I) in
    rotation (plane stress: pure tension and pure bending are quadratic fields, which the
    quadratic elements hold exactly, and the end tractions are integrated exactly): what
    is left is the two meshes' difference round the neck, 8e-6 at 6 elements across
    (1.5e-4 at 3), hence 1e-4."""
    short, long = (fe_compliance(0.75, NECK_MM, 22.0, 0.4, link_mm=ll) for ll in (5.0, 7.0))
    w = LINK_MM[0]
    assert long[0, 0] - short[0, 0] == pytest.approx(2.0 / (E_MPA * w), rel=1e-4)
    assert long[2, 2] - short[2, 2] == pytest.approx(2.0 * 12 / (E_MPA * w**3), rel=1e-4)


def test_fe_reference_is_mesh_converged():
    """6 and 9 elements across the neck (and the fillet's radius) agree within 0.05 % on the
    leaning hinge's rotation and its coupling to a transverse force (measured 1e-5)."""
    coarse, fine = (fe_compliance(0.75, NECK_MM, 32.3, 0.4, n_across=n) for n in (6.0, 9.0))
    assert coarse[2, 2] == pytest.approx(fine[2, 2], rel=5e-4)
    assert coarse[1, 2] == pytest.approx(fine[1, 2], rel=5e-4)


def test_root_depth_grows_with_t_sin_gamma(fe, monkeypatch):
    """The rule's form, its two depth constants fitted to these 13 substructures alone
    (measured: 0.48 t + 0.52 t sin gamma), holds every one within 1 % (measured 0.59 %:
    the beam model's own accuracy on one hinge, its shear and fillet terms included); the
    best depth that ignores the lean, chosen for the smallest worst error, cannot
    (measured 2.24 % at 0.60 t: the leaning thick hinges softer than it says, the square
    ones stiffer)."""
    with_lean = minimize(lambda p: np.sqrt(np.mean(errors_pct(fe, monkeypatch, *p) ** 2)),
                         [0.5, 0.5], method="Nelder-Mead", options={"xatol": 1e-3, "fatol": 1e-3})
    without = minimize_scalar(lambda a: np.abs(errors_pct(fe, monkeypatch, a, 0.0)).max(),
                              bounds=(0.2, 1.2), method="bounded", options={"xatol": 1e-3})
    assert with_lean.x[1] > 0.3, with_lean.x
    assert np.abs(errors_pct(fe, monkeypatch, *with_lean.x)).max() < 1.0, with_lean.x
    assert without.fun > 2.0, (without.x, without.fun)


def test_stored_rule_against_every_substructure(fe, monkeypatch):
    """The stored constants, fitted to whole bodies, against the isolated hinge. Measured:
    rotation -3.6 to +0.7 %, its coupling to a transverse force (where the hinge's effective
    pivot sits; its sign checks the load and transport conventions) -4.6 to +1.6 %: the
    bodies want a shallower root at a square face and a deeper one at a leaning face than one
    hinge in a clamped block shows, what their knees, plates and links add round the roots.
    A guard, not a target: 5 and 6 %, 1-1.5 points over the measured, so that a refit
    pulling the rule further from one hinge's mechanics is looked at."""
    stored = topology.ROOT_DEPTH_PER_THICKNESS, topology.ROOT_DEPTH_PER_LEAN
    assert np.abs(errors_pct(fe, monkeypatch, *stored)).max() < 5.0
    assert np.abs(errors_pct(fe, monkeypatch, *stored, entry=(1, 2))).max() < 6.0


def test_fillet_centroid_offset_gives_part_of_the_oblique_roots_coupling(fe):
    """Where the face leans, the FE's end turns under an axial force (C[0, 2], the
    axial-bending coupling). The beam model's comes from the fillets' centroid offset alone
    (geometry.topology.hinge_profile): the FE's sign on every leaning substructure, and
    measured 11-61 % of its size, most on the thinnest hinge (the rest is the oblique root's
    own, which whole bodies do not show: README, the part as cut), hence 5-80 %; none on a
    square face (FE within 1e-7 of 0, against 5e-4 to 7e-3 leaning)."""
    for (t, gamma, r), c in fe.items():
        beam = beam_compliance(t, NECK_MM, gamma, r)[0, 2]
        if gamma == 0.0:
            assert beam == 0.0 and abs(c[0, 2]) < 1e-6, (t, gamma, r, c[0, 2])
        else:
            assert 0.05 < beam / c[0, 2] < 0.8, (t, gamma, r, beam, c[0, 2])


@pytest.mark.parametrize("r", [0.0, 0.4])
def test_outline_has_no_zero_width_spike_at_any_lean(r):
    """The substructure's outline at every lean of the table's faces (0-34 deg) and hinges
    of 0.3-1.25 mm: no vertex where the outline turns back on itself (its two edges
    anti-parallel). With the neck's strip ending on the link's edge, the union left one at
    gamma 20 deg (t 0.3 mm, sharp), and gmsh made no triangles of it."""
    from tests.mechanics.hinge_substructure import outline

    for t in (0.3, 0.75, 1.25):
        for gamma in np.arange(0.0, 34.5, 0.5):
            xy = np.array(outline(t, NECK_MM, gamma, r).exterior.coords)[:-1]
            e = np.roll(xy, -1, axis=0) - xy
            e /= np.linalg.norm(e, axis=1)[:, None]
            turn_back = np.einsum("ij,ij->i", e, np.roll(e, 1, axis=0))
            assert turn_back.min() > -0.999, (t, gamma)


def test_fe_reference_meshes_the_sharp_oblique_root():
    """The case that gmsh could not mesh (t 0.3 mm, gamma 20 deg, sharp): its compliance is
    symmetric positive definite (a reciprocal, stable elastic body)."""
    c = fe_compliance(0.3, NECK_MM, 20.0, 0.0)
    assert np.allclose(c, c.T, rtol=1e-6, atol=1e-9) and np.all(np.linalg.eigvalsh(c) > 0)
