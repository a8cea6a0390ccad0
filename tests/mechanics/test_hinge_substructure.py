"""The root rule's form against a continuum model of one hinge (tests/mechanics/
hinge_substructure.py): a neck between a block, whose face leans gamma, and a link, in
plane stress, against the beam model's hinge member (geometry.topology.root_depth_mm).

The rule's depth constants are fitted to the bodies of the continuum table
(tests/mechanics/test_root_rule.py); these tests check its form on a reference that no fit
of them has seen: the rotational compliance of a root grows with t sin(gamma). The oblique
root's axial coupling (geometry.topology.ROOT_COUPLING_PER_LEAN) and the axial compliance
of the stress spreading into the block (geometry.topology.axial_spread) are fitted here, on
one hinge alone, and not on bodies."""

import numpy as np
import pytest
from scipy.optimize import least_squares, minimize, minimize_scalar

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
    (measured: 0.45 t + 0.52 t sin gamma), holds every one within 1 % (measured 0.42 %:
    the beam model's own accuracy on one hinge, its shear and fillet terms included); the
    best depth that ignores the lean, chosen for the smallest worst error, cannot
    (measured 2.27 % at 0.57 t: the leaning thick hinges softer than it says, the square
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
    rotation -1.9 to +1.3 %, its coupling to a transverse force (where the hinge's effective
    pivot sits; its sign checks the load and transport conventions) -2.3 to +1.8 %: the
    bodies want a slightly shallower root at a square face and a deeper one at a leaning face
    than one hinge in a clamped block shows, what their knees, plates and links add round the
    roots (before the oblique root's coupling was in the model, -3.6 to +0.7 and -4.6 to
    +1.6 %: the lean term then stood in for part of it). A guard, not a target: 3 and 3.5 %,
    1-1.2 points over the measured, so that a refit pulling the rule further from one hinge's
    mechanics is looked at."""
    stored = topology.ROOT_DEPTH_PER_THICKNESS, topology.ROOT_DEPTH_PER_LEAN
    assert np.abs(errors_pct(fe, monkeypatch, *stored)).max() < 3.0
    assert np.abs(errors_pct(fe, monkeypatch, *stored, entry=(1, 2))).max() < 3.5


#: The leaning substructures and two sharp-rooted ones: the oblique root's coupling
#: (geometry.topology.ROOT_COUPLING_PER_LEAN) is fitted on them.
COUPLED = [s for s in SUBSTRUCTURES if s[1] != 0.0] + [(0.75, 15.0, 0.0), (0.75, 32.3, 0.0)]


def coupling_ratios(coupled, monkeypatch, k) -> np.ndarray:
    """(n, 2): the beam's axial couplings C[0, 1] (transverse) and C[0, 2] (rotation) over the
    FE's, with the root coupling constant k."""
    monkeypatch.setattr(topology, "ROOT_COUPLING_PER_LEAN", float(k))
    topology.hinge_profile.cache_clear()
    ratios = [[beam_compliance(s[0], NECK_MM, *s[1:])[0, j] / coupled[s][0, j] for j in (1, 2)] for s in COUPLED]
    topology.hinge_profile.cache_clear()
    return np.array(ratios)


@pytest.fixture(scope="module")
def coupled(fe):
    return {s: fe[s] if s in fe else fe_compliance(s[0], NECK_MM, *s[1:]) for s in COUPLED}


def test_square_faces_have_no_axial_coupling(fe):
    """A square face is symmetric about the neck: no coupling in either model (FE within 1e-7
    of 0, against 5e-4 to 7e-3 on a leaning face)."""
    for (t, gamma, r), c in fe.items():
        if gamma == 0.0:
            assert beam_compliance(t, NECK_MM, gamma, r)[0, 2] == 0.0 and abs(c[0, 2]) < 1e-6, (t, r)


def test_oblique_roots_coupling_is_the_least_squares_fit(coupled, monkeypatch):
    """Where the face leans, the FE's end turns (C[0, 2]) and moves across (C[0, 1]) under an
    axial force. The fillets' centroid offset alone gives 11-62 % of it (measured; none at
    the sharp roots, which have no fillets); the root's
    own, k sin(gamma) / (E b t) at each leaning root, makes up the rest. k is the least-squares
    fit of both relative errors over these ten hinges (linear in k: refitted here in closed
    form, measured 1.981); the stored constant is that fit to 0.01."""
    stored = topology.ROOT_COUPLING_PER_LEAN
    without, unit = coupling_ratios(coupled, monkeypatch, 0.0), coupling_ratios(coupled, monkeypatch, 1.0)
    assert without.max() < 0.7 and without.min() > -1e-12, without
    slope = (unit - without).ravel()
    k = slope @ (1.0 - without.ravel()) / (slope @ slope)
    assert stored == pytest.approx(k, abs=0.01)


def test_oblique_roots_coupling_holds_every_hinge(coupled, monkeypatch):
    """With the stored constant, both couplings within 20 % of the FE's on every leaning hinge
    (measured -14.4 to +16.3 %: one constant over fillets of 0 to 0.6 mm, the sharp roots'
    coupling 10-16 % below it, the widest fillets' up to 14 % above), where the fillets'
    offset alone is 38-89 % short; the sign is the FE's on every one."""
    ratios = coupling_ratios(coupled, monkeypatch, topology.ROOT_COUPLING_PER_LEAN)
    assert np.abs(ratios - 1.0).max() < 0.20, np.round(100 * (ratios - 1.0), 1)


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


#: (t, gamma_deg, r, block depth) mm, deg, mm, mm: hinges of 0.3-1.25 mm, square and leaning,
#: sharp and with the 0.8 mm jet's fillets, in blocks 2 mm deep (a plate, a knee block) and
#: 6 mm deep (the root rule's substructures)
SPREAD_CASES = [(t, g, r, d) for t in (0.3, 0.75, 1.25) for g in (0.0, 20.0) for r in (0.0, 0.4) for d in (2.0, 6.0)]


@pytest.fixture(scope="module")
def axial():
    """Per case of SPREAD_CASES, the FE's axial compliance and the beam's without the spread
    (mm/N, unit depth)."""
    out = {}
    for t, g, r, d in SPREAD_CASES:
        beam = beam_compliance(t, NECK_MM, g, r, depth_mm=d)[0, 0] - topology.axial_spread(t, r, d) / E_MPA
        out[(t, g, r, d)] = (fe_compliance(t, NECK_MM, g, r, depth_mm=d)[0, 0], beam)
    return out


def spread_errors(axial, per_depth, per_fillet, monkeypatch) -> np.ndarray:
    """The beam's axial compliance against the FE's (fractions) with the given spread
    constants."""
    monkeypatch.setattr(topology, "AXIAL_SPREAD_PER_DEPTH", float(per_depth))
    monkeypatch.setattr(topology, "AXIAL_SPREAD_PER_FILLET", float(per_fillet))
    return np.array([(beam + topology.axial_spread(t, r, d) / E_MPA) / fe - 1.0
                     for (t, _, r, d), (fe, beam) in axial.items()])


def test_member_alone_misses_the_axial_spread(axial):
    """Without the spread, the hinge member's axial compliance is 10-25 % short of the FE's on
    every case (measured 10.5-20.3 %), growing with the block's depth: the force spreading into
    the block, which the root depth (fitted on bending) does not carry."""
    short = np.array([1.0 - beam / fe for fe, beam in axial.values()])
    assert short.min() > 0.10 and short.max() < 0.25, np.round(100 * short, 1)
    deep = {k: v for k, v in zip(axial, short)}
    assert all(deep[(t, g, r, 6.0)] > deep[(t, g, r, 2.0)] for t, g, r, _ in SPREAD_CASES)


def test_axial_spread_is_the_least_squares_fit(axial, monkeypatch):
    """The two constants of geometry.topology.axial_spread are the least-squares fit of the
    relative axial error over these cases: the stored ones' RMS within 0.1 percentage point
    of the refit's (they were fitted on a finer grid of 96 cases, D 2, 3 and 6 mm and r 0-0.6
    mm)."""
    stored = spread_errors(axial, topology.AXIAL_SPREAD_PER_DEPTH, topology.AXIAL_SPREAD_PER_FILLET, monkeypatch)
    fit = least_squares(lambda p: spread_errors(axial, *p, monkeypatch), [1.5, 0.2], bounds=([0.1, 0.0], [10.0, 5.0]))
    rms = lambda e: 100 * float(np.sqrt(np.mean(np.square(e))))
    assert rms(stored) <= rms(fit.fun) + 0.1, (fit.x, rms(fit.fun), rms(stored))


def test_axial_spread_holds_every_case(axial, monkeypatch):
    """With the stored constants the axial compliance is within 4 % of the FE's on every case
    (measured -3.4 to +2.7 %), where it was 10.5-20.3 % short."""
    errors = spread_errors(axial, topology.AXIAL_SPREAD_PER_DEPTH, topology.AXIAL_SPREAD_PER_FILLET, monkeypatch)
    assert np.abs(errors).max() < 0.04, np.round(100 * errors, 2)
