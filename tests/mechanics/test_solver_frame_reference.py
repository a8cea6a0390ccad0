"""The solver against an independent geometrically exact frame model (issue 3).

Requirement: an independent frame model of the same topology agrees on A and k_out at 1 mm
output within 2 %. The reference (tests/mechanics/frame_reference.py) splits each compliant member into
n Simo-Reissner segments and solves dPi/dq = 0 under the solver's final input force applied as
a dead load; it shares no code with sensor.mechanics.solver.

Measured (n = 32, relative difference solver/reference - 1, at the solver's 1-mm force):

    preset            A        k_out    SE
    basis            +0.00 %  -0.01 %   +0.01 %
    sample-a         +0.02 %  +0.01 %   -0.04 %
    sample-b         +0.05 %  +0.08 %   -0.19 %
    basis-as-cut     -0.00 %  -0.01 %   +0.01 %
    sample-a-as-cut  +0.01 %  +0.01 %   -0.03 %
    sample-b-as-cut  +0.05 %  +0.08 %   -0.20 %

(since the hinges' centroid offset: the reference's segments follow the centroids)

Before the solver's members carried the bowing (shallow-arch) term, its one linear element
per member left sample-b's k_out 2.4 % low; splitting members converged it as 1/n^2. With the
bowing term the coupling of axial force and bending inside a member is captured and the
single-element solver agrees within 0.3 % everywhere.
"""

from functools import lru_cache

import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.optimize import brentq

from geometry.params import PRESETS, preset
from geometry.topology import BeamModel, build_beam_model
from sensor.mechanics.solver import solve
from tests.mechanics.frame_reference import (
    discretise,
    hessian,
    potential,
    solve_dead_load,
    split_members,
)

N_REF = 32          # reference segments per compliant member (refinement study below)
REQUIREMENT = 0.02  # issue 3: A and k_out within 2 %
SPECIMENS = ("basis", "sample-a", "sample-b")


@lru_cache(maxsize=None)
def model(name: str) -> BeamModel:
    return build_beam_model(preset(name))


@lru_cache(maxsize=None)
def main(name: str):
    return solve(model(name))


@lru_cache(maxsize=None)
def reference(name: str, n: int = N_REF, force: float | None = None):
    return solve_dead_load(model(name), main(name).input_force_N if force is None else force,
                           n_segments=n)


def rel(a: float, b: float) -> float:
    return abs(a / b - 1.0)


# --- the reference model itself ---------------------------------------------------------

def test_reference_gradient_and_hessian_match_central_differences():
    """Analytic dPi/dq and d2Pi/dq2 against central differences at a random large-rotation
    state (rotations ~0.3 rad). Step 1e-6: truncation ~1e-12 relative, round-off ~1e-10 of the
    largest entry, so 1e-7 of the largest entry is a safe bound."""
    frame = discretise(model("sample-b"), 2)
    q = np.random.default_rng(1).normal(scale=0.3, size=frame.n_dof)
    force, h = 3.0, 1e-6
    _, g = potential(frame, q, force)
    H = hessian(frame, q, force).toarray()
    eye = np.eye(frame.n_dof)
    g_fd = np.array([(potential(frame, q + h * e, force)[0] - potential(frame, q - h * e, force)[0])
                     / (2 * h) for e in eye])
    H_fd = np.array([(potential(frame, q + h * e, force)[1] - potential(frame, q - h * e, force)[1])
                     / (2 * h) for e in eye])
    assert np.abs(g - g_fd).max() <= 1e-7 * np.abs(g).max()
    assert np.abs(H - H_fd).max() <= 1e-7 * np.abs(H).max()


def cantilever(L, t, b, E=2300.0, nu=0.35) -> BeamModel:
    """One compliant member along x, clamped at node 0, tip load -y at node 1."""
    return BeamModel(np.array([[0.0, 0.0], [L, 0.0]]), np.array([[0, 1]]), ("hinge",),
                     np.array([t]), np.array([b]), np.zeros(1, int), ("beam",),
                     ((0, ("x", "y", "rz")),), 1, np.array([0.0, -1.0]), 1,
                     np.array([0.0, -1.0]), E, nu)


@pytest.mark.parametrize("n", [1, 4, N_REF])
def test_reference_small_load_matches_discrete_timoshenko_cantilever(n):
    """A stubby hinge-like cantilever (L/t = 5.5, shear ~3 % of the deflection) under a small
    tip load. The exact Timoshenko deflection is P L^3 / 3EI + (6/5) P L / GA; n segments
    with one-point integration give exactly P L^3 / 3EI (1 - 1 / 4n^2) + (6/5) P L / GA
    (n = 1: a shear-rigid segment yields P L^3 / 4EI). The load is small (tip slope 1e-6),
    so the nonlinear remainder is ~1e-12 and 1e-9 holds."""
    L, t, b, E, nu = 2.75, 0.5, 5.1, 2300.0, 0.35
    P = 1e-4
    r = solve_dead_load(cantilever(L, t, b, E, nu), P, n_segments=n, load_steps=1)
    I, A, G = b * t**3 / 12, t * b, E / (2 * (1 + nu))
    expected = P * L**3 / (3 * E * I) * (1 - 1 / (4 * n**2)) + 1.2 * P * L / (G * A)
    assert r.output_travel_mm == pytest.approx(expected, rel=1e-9)


def elastica_tip_deflection(alpha: float) -> float:
    """Tip deflection / L of an inextensible cantilever under a dead transverse tip load with
    load index alpha = P L^2 / EI: phi'' = -alpha cos(phi), phi(0) = 0, phi'(1) = 0, solved by
    shooting on phi'(0) (independent of both frame models)."""
    def shoot(k0):
        sol = solve_ivp(lambda s, y: [y[1], -alpha * np.cos(y[0]), np.sin(y[0])], (0, 1),
                        [0.0, k0, 0.0], rtol=1e-12, atol=1e-14)
        return sol.y[:, -1]
    k0 = brentq(lambda k: shoot(k)[1], 0.0, alpha, xtol=1e-14)
    return shoot(k0)[2]


@pytest.mark.parametrize("alpha", [1.0, 5.0])
def test_reference_large_deflection_matches_elastica(alpha):
    """A slender cantilever (L/t = 200: shear and stretch ~1e-5 of the deflection) at load
    index 1 (tip slope 28 deg) and 5 (63 deg) against the shooting elastica. The discretisation
    error at n = 32 is ~1e-4; 5e-4 bounds it."""
    L, t, b, E = 100.0, 0.5, 5.0, 2300.0
    EI = E * b * t**3 / 12
    r = solve_dead_load(cantilever(L, t, b, E), alpha * EI / L**2, n_segments=N_REF, load_steps=8)
    assert r.output_travel_mm / L == pytest.approx(elastica_tip_deflection(alpha), rel=5e-4)


@pytest.mark.parametrize("name", SPECIMENS)
def test_reference_is_converged_in_the_number_of_segments(name):
    """n = 16 -> 32 changes A, k_out and SE by < 1e-3 (measured <= 1.6e-4); with the O(1/n^2)
    error of one-point integration, the n = 32 values are then within ~3e-4 of the limit,
    negligible against the 2 % under test."""
    coarse, fine = reference(name, 16), reference(name, N_REF)
    assert fine.gradient_norm < 1e-8 * fine.force_N and coarse.gradient_norm < 1e-8 * coarse.force_N
    for key in ("amplification", "k_out_N_per_mm", "strain_energy_mJ"):
        assert rel(getattr(coarse, key), getattr(fine, key)) < 1e-3, key


# --- the solver against the reference ------------------------------------------------------

@pytest.mark.parametrize("name", SPECIMENS)
def test_solver_matches_reference_in_the_linear_limit(name):
    """At 1e-4 of the 1-mm force both models are linear Timoshenko frames (the solver's
    Castigliano stiffness is exact there), so they differ by the reference's O(1/n^2)
    discretisation (measured <= 6e-5 at n = 32, 2.3e-4 at n = 16, on sections centred on
    the axis), ~1e-6 of nonlinearity, and where a leaning face's fillets move the sections'
    centroid off the axis, by the reference's straight segments along the centroids'
    polyline (inclined up to about 19 deg there, each with its share of the chord's
    compliance), which share an axial force between their stretch and shear where the
    solver's sections stay square to the axis: an O(slope^2) difference of the two
    idealisations, measured <= 3.1e-4 (sample B's A and SE; k_out 5e-5) at n = 32 and 64
    alike. Hence 5e-4, forty times tighter than the 2 % at 1 mm."""
    force = 1e-4 * main(name).input_force_N
    r = solve(model(name), target_force_N=force)
    f = reference(name, N_REF, force)
    assert rel(r.amplification, f.amplification) < 5e-4
    assert rel(r.k_out_N_per_mm, f.k_out_N_per_mm) < 5e-4
    assert rel(r.strain_energy_mJ, f.strain_energy_mJ) < 5e-4


@pytest.mark.parametrize("name", PRESETS)
def test_solver_amplification_matches_reference_at_1mm(name):
    """Issue 3: A within 2 % at the solver's 1-mm force (dead load; measured <= 0.96 %)."""
    assert rel(main(name).amplification, reference(name).amplification) < REQUIREMENT


@pytest.mark.parametrize("name", PRESETS)
def test_solver_output_stiffness_matches_reference_at_1mm(name):
    """Issue 3: k_out = F / u_out within 2 % at the solver's 1-mm force (measured <= 0.08 %)."""
    assert rel(main(name).k_out_N_per_mm, reference(name).k_out_N_per_mm) < REQUIREMENT


@pytest.mark.parametrize("name", SPECIMENS)
def test_solver_stays_on_the_reference_when_members_are_split(name):
    """Splitting every compliant member in 2 or 4 changes nothing that matters: the solver
    stays within 0.3 % of the reference on A, k_out and SE (measured <= 0.22 %, sample B's
    SE with the cut part's profiled hinges, whose pieces each carry a part of the fillets;
    the reference's own discretisation error at n = 32 is ~1e-4)."""
    f = reference(name)
    force = main(name).input_force_N
    for n in (2, 4):
        r = solve(split_members(model(name), n), target_force_N=force)
        for key in ("amplification", "k_out_N_per_mm", "strain_energy_mJ"):
            assert rel(getattr(r, key), getattr(f, key)) < 3e-3, (n, key)


@lru_cache(maxsize=None)
def near_toggle():
    """like-4 of the continuum table (phi2 10.4 deg, A falls to 0.7 of its linear value by
    1 mm): (beam model, solver at 1 mm, reference at the solver's force, n = N_REF)."""
    from geometry.params import design_from_dict
    from tests.mechanics.test_continuum_table import ENTRIES

    m = build_beam_model(design_from_dict(ENTRIES["like-4-delrin"]["design"]))
    r = solve(m, target_output_mm=1.0)
    return m, r, solve_dead_load(m, r.input_force_N, n_segments=N_REF)


def test_solver_matches_reference_at_1mm_next_to_the_toggle():
    """Issue 3's 2 % on a body next to the toggle, where the hinges carry 50 N and turn 7
    deg: A and k_out within 0.5 % (measured -0.33 and +0.44 %, the reference moving 0.1 %
    from n = 16 to 32; -0.80 and +0.87 % before the members carried the oblique roots'
    centroid offset at second order, profile_bowing's d1, d2; the 0.3 % a strict expected
    failure asked of the mended element is not reached), and the solver with every member
    split in 8 within 0.2 % (measured 0.09 and 0.11 %: what is left is the one element's
    discretisation, as on uniform hinges, not the model's). Both models carry the material
    law's cubic term (St Venant-Kirchhoff's), each in its own discretisation."""
    m, r, f = near_toggle()
    assert rel(r.amplification, f.amplification) < 0.005
    assert rel(r.k_out_N_per_mm, f.k_out_N_per_mm) < 0.005
    split = solve(split_members(m, 8), target_force_N=r.input_force_N)
    assert rel(split.amplification, f.amplification) < 2e-3
    assert rel(split.k_out_N_per_mm, f.k_out_N_per_mm) < 2e-3


@pytest.mark.parametrize("name, guided, stable", [("basis", True, True), ("sample-a", True, True),
                                                  ("sample-b", True, True), ("sample-b", False, False)])
def test_reference_stability_of_the_symmetric_1mm_state(name, guided, stable):
    """With the input free sideways, nominal sample-b has a sway bifurcation at ~6.46 N
    (reference, n = 16 and 32: the lowest Hessian eigenvalue, linear in the load, crosses
    zero), below its 1-mm force: the symmetric state is a saddle of the total potential with
    one negative mode, and the main solver reports it (test_solver). With the input guided
    as by the thesis' stage (x and rotation held) it is stable."""
    m = model(name) if guided else build_beam_model(preset(name), input_guided=False)
    assert solve_dead_load(m, main(name).input_force_N, n_segments=16).negative_modes == (0 if stable else 1)


def test_reference_rejects_bad_input():
    with pytest.raises(ValueError, match="n_segments = 0"):
        discretise(model("basis"), 0)
    with pytest.raises(ValueError, match="force_N = -1"):
        solve_dead_load(model("basis"), -1.0)
