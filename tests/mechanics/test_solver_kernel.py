"""The compiled solver kernel's linear algebra and tangent against independent computations:
LAPACK (numpy.linalg) for the banded elimination and the Cholesky test, and central finite
differences of the out-of-balance forces for the tangent stiffness."""

import numpy as np
import pytest

from geometry.params import preset
from geometry.topology import build_beam_model
from sensor.mechanics import _solver_kernel as K
from sensor.mechanics.solver import _make_batch, prepare


def banded_bordered(n, band, border, rng):
    """A random n x n matrix with nonzeros within ``band`` of the diagonal, plus ``border``
    dense last rows and columns (the displacement-control row and column)."""
    A = rng.standard_normal((n, n))
    i, j = np.indices((n, n))
    core = n - border
    A[(np.abs(i - j) > band) & (i < core) & (j < core)] = 0.0
    return A


@pytest.mark.parametrize("n, band, border", [(53, 8, 1), (52, 8, 0), (12, 11, 0), (30, 3, 1)])
def test_banded_elimination_matches_lapack(n, band, border):
    """Random matrices need pivoting (diagonals are not dominant): the solution agrees with
    numpy.linalg.solve to round-off (1e-10 relative; both are backward stable and these
    matrices have condition numbers ~1e2-1e4)."""
    rng = np.random.default_rng(n + band)
    for _ in range(20):
        A = banded_bordered(n, band, border, rng)
        b = rng.standard_normal(n)
        W = np.zeros((n + 1, n + 2))
        W[:n, :n], W[:n, n] = A, b
        core = np.arange(n - border)
        end = np.minimum(core + band, n - border - 1)
        assert K.solve_in_place(W, n, n - border, end, end)
        x = np.linalg.solve(A, b)
        assert np.max(np.abs(W[:n, n] - x)) <= 1e-10 * np.max(np.abs(x))


def test_exactly_singular_system_is_reported():
    A = np.diag([2.0, 1.0, 0.0, 3.0])
    W = np.zeros((5, 6))
    W[:4, :4], W[:4, 4] = A, 1.0
    assert not K.solve_in_place(W, 4, 4, np.arange(4), np.arange(4))


@pytest.mark.parametrize("shift, expected", [(+0.5, True), (-0.5, False)])
def test_positive_definiteness_matches_cholesky(shift, expected):
    """A banded symmetric matrix shifted just above / below its smallest eigenvalue (the
    asymmetric part is ignored, as the solver's stability test symmetrises the tangent)."""
    rng = np.random.default_rng(1)
    S = banded_bordered(40, 5, 0, rng)
    S = S + S.T
    S += (shift - np.linalg.eigvalsh(S).min()) * np.eye(40)
    skew = np.triu(rng.standard_normal((40, 40)) * (np.abs(np.subtract.outer(range(40), range(40))) <= 5), 1)
    start, reach = np.maximum(np.arange(40) - 5, 0), np.minimum(np.arange(40) + 5, 39)
    assert K.positive_definite(S + skew - skew.T, np.zeros((40, 40)), start, reach) is expected


@pytest.mark.parametrize("name", ["basis", "sample-b"])
def test_tangent_is_the_derivative_of_the_out_of_balance_forces(name):
    """At a deformed state under load, every column of the assembled tangent (dead input
    load included) equals the central difference of the residual: 1e-6 relative to the
    largest entry, which is ~1e4 N/mm: the geometric terms (~lam / L ~ 1 N/mm) are
    resolved (measured 1e-9; step 1e-6 of the dof scale, truncation ~1e-12)."""
    model = build_beam_model(preset(name))
    topo = prepare(model)
    bt = _make_batch(topo, [model])
    w = K.work(topo.n_nodes, topo.n_dof)
    rng = np.random.default_rng(0)
    q = rng.standard_normal((len(topo.master_of_body), 3)) * np.array([0.05, 0.05, 0.01])
    q[~topo.free_body] = 0.0
    lam = 3.0

    def residual(qq):
        K._evaluate(qq, lam, topo.kernel_args, bt.kernel_args, 0, w)
        return w.F.copy(), w.Kg.copy()

    _, tangent = residual(q)
    fd = np.zeros_like(tangent)
    for c, k in zip(*np.nonzero(topo.dof_of_body >= 0)):
        h = 1e-6 * (1.0 if k < 2 else 0.1)
        dq = np.zeros_like(q)
        dq[c, k] = h
        fd[:, topo.dof_of_body[c, k]] = (residual(q + dq)[0] - residual(q - dq)[0]) / (2 * h)
    assert np.max(np.abs(tangent - fd)) <= 1e-6 * np.max(np.abs(tangent))


def one_member(kn, bw, L, u, th, w):
    """The kernel's element for one member of chord (L, 0) from node 0 to node 1 (their
    bodies' offsets zero): (strain energy, chord-frame forces qf, node forces f)."""
    qf = np.empty(3)
    energy = K.element(0, np.array([0]), np.array([1]), np.array([[L, 0.0]]), np.array([L]), np.zeros(1),
                       kn[None], bw[None], u, th, np.zeros((2, 2)), np.empty(3), qf, w.f, w.Ke, w.Bm, w.KB, w.z, w.r)
    return energy, qf, w.f.copy()


def exact_end_stiffness(phi):
    """Rotational stiffness (k_aa, k_ab) x L / EI of a uniform Euler-Bernoulli member under an
    axial force N, phi = N L^2 / EI (tension positive), ends held on the chord: the stability
    functions (Timoshenko & Gere, Theory of Elastic Stability, section 1.9)."""
    u = np.sqrt(abs(phi))
    if phi > 0:
        d = 2 - 2 * np.cosh(u) + u * np.sinh(u)
        return u * (u * np.cosh(u) - np.sinh(u)) / d, u * (np.sinh(u) - u) / d
    d = 2 - 2 * np.cos(u) - u * np.sin(u)
    return u * (np.sin(u) - u * np.cos(u)) / d, u * (u - np.sin(u)) / d


@pytest.mark.parametrize("phi", [-5.0, -2.0, 2.0, 5.0])
@pytest.mark.parametrize("second_order", [True, False])
def test_member_end_moments_follow_the_stability_functions(phi, second_order):
    """One uniform member (shear-stiff) stretched or shortened to the axial force
    N = phi EI / L^2 and turned at its ends by 1e-6 rad: its end moments against the exact
    beam-column's. With the bowing's first-order term and the N^2 term (coefficients from
    profile_bowing of the uniform profile) the series is right to phi^2, so what is left
    is its phi^3 term: 0.16 % of k_aa at phi = -5 (the compressed knee hinges of a
    toggle-band body reach -4.8), hence the bound 0.2 % (|phi| / 5)^3. Without the N^2 term
    (``second_order`` False, the element before it) the error is ~11 phi^2 / 6300 / 4:
    0.9-1.5 % at |phi| = 5, over the bound 0.5 % (phi / 5)^2 the test also checks, so it
    tells the two apart. The material law's cubic term is left out (its coefficients zero):
    the stability functions are Hooke's law's."""
    from sensor.mechanics.solver import natural_stiffness, profile_bowing

    L, t, b, E = 2.0, 0.4, 6.0, 2000.0
    EI = E * b * t**3 / 12
    stations = np.column_stack([np.linspace(0, L, 9), np.full(9, t)])
    bw = np.r_[profile_bowing(stations) * np.r_[1, 1, 1, np.full(5, 12 / (E * b))], np.zeros(4)]
    if not second_order:
        bw[3:] = 0.0
    kn = natural_stiffness(L, t, b, E, 1e9)
    N = phi * EI / L**2
    stretch = N / kn[0, 0]
    exact = np.array(exact_end_stiffness(phi)) * EI / L
    w = K.work(2, 6)
    for theta, column in (((1e-6, 0.0), 0), ((0.0, 1e-6), 1)):
        u = np.array([[0.0, 0.0], [stretch, 0.0]])
        th = np.array(theta)
        _, qf, _ = one_member(kn, bw, L, u, th, w)
        k_aa, k_ba = qf[1 + column] / 1e-6, qf[2 - column] / 1e-6
        err = max(abs(k_aa / exact[0] - 1), abs(k_ba - exact[1]) / exact[0])
        if second_order:
            assert err < 2e-3 * (abs(phi) / 5) ** 3, err
        else:
            assert err > 5e-3 * (phi / 5) ** 2, err


def test_member_forces_are_the_gradient_of_its_strain_energy():
    """One member with a tapered, asymmetric neck (0.9 -> 0.3 -> 0.6 mm, its centroid off the
    axis so that Kn couples stretch and bending and the N^2 term has its d1, d2), stretched
    and turned far (ends 0.2 and -0.15 rad, chord turned 0.1 rad): the node forces the
    kernel returns are the central differences of the strain energy it returns (the strain
    energy the solver reports is the one its equilibrium minimises), and its tangent the
    central differences of those forces, each to 1e-6 relative of its largest entry (step
    1e-6, truncation ~1e-12; the N^2 term and the material law's cubic term are exaggerated
    1000 times so that they show)."""
    from sensor.mechanics.solver import (
        _profile_integrals,
        material_coefficients,
        natural_stiffness,
        profile_bowing,
        profile_flexibility,
    )

    E, b = 2000.0, 6.0
    stations = np.array([[0.0, 0.9, 0.05], [1.2, 0.3, 0.0], [3.0, 0.6, -0.02]])
    L = stations[-1, 0]
    kn = natural_stiffness(L, 0.3, b, E, E / 2.7, profile_flexibility(stations, b, E, E / 2.7))
    bw = np.r_[profile_bowing(stations) * np.r_[1, 1, 1, np.full(5, 12e3 / (E * b))],
               1e3 * material_coefficients(_profile_integrals(stations)[7:], b, E, 0.35)]
    assert np.all(bw[6:] != 0.0)
    w = K.work(2, 6)

    def energy_force_tangent(x):
        energy, _, f = one_member(kn, bw, L, np.array([[x[0], x[1]], [x[3], x[4]]]), np.array([x[2], x[5]]), w)
        return energy, f, w.Ke.copy()

    x = np.array([0.0, 0.0, 0.2, 0.004, 0.1 * L, -0.15])
    _, f, tangent = energy_force_tangent(x)
    h = 1e-6
    grad = np.array([(energy_force_tangent(x + h * e)[0] - energy_force_tangent(x - h * e)[0]) / (2 * h)
                     for e in np.eye(6)])
    assert np.max(np.abs(grad - f)) <= 1e-6 * np.max(np.abs(f)), (grad, f)
    hess = np.array([(energy_force_tangent(x + h * e)[1] - energy_force_tangent(x - h * e)[1]) / (2 * h)
                     for e in np.eye(6)])
    assert np.max(np.abs(hess - tangent)) <= 1e-6 * np.max(np.abs(tangent))


@pytest.mark.parametrize("nu", [0.0, 0.35])
def test_member_energy_carries_the_section_law_cubic_term(nu):
    """A uniform member bent to a constant curvature kappa (ends turned -+theta / 2 from the
    chord) and stretched to an axial strain +-eps of its axis: the part of the kernel's
    strain energy odd in eps is the section law's, 2 L (3/2 (1 - nu) EI eps kappa^2 +
    EA eps^3 / 2) (solver.material_coefficients; the continuum strip's in
    tests/mechanics/test_material_law.py), to 1e-9 relative: the quadratic and the n^2
    terms are even in eps. Strains 0.1 % and 1.5 %."""
    from sensor.mechanics.solver import _profile_integrals, material_coefficients, natural_stiffness, profile_bowing

    L, t, b, E = 3.0, 0.5, 5.0, 2000.0
    EI, EA = E * b * t**3 / 12, E * b * t
    G = E / (2 * (1 + nu))
    kn = natural_stiffness(L, t, b, E, G)
    stations = np.array([[0.0, t], [L, t]])
    bw = np.r_[profile_bowing(stations) * np.r_[1, 1, 1, np.full(5, 12 / (E * b))],
               material_coefficients(_profile_integrals(stations)[7:], b, E, nu)]
    w = K.work(2, 6)
    eps, kappa = 1e-3, 0.06
    theta = kappa * L
    bow = (bw[0] - bw[1] + bw[2]) * theta**2 / 4

    def energy(e):  # the axis stretched e: the chord by e L less the bowing
        u = np.array([[0.0, 0.0], [e * L - bow, 0.0]])
        return one_member(kn, bw, L, u, np.array([-theta / 2, theta / 2]), w)[0]

    odd = energy(eps) - energy(-eps)
    expected = 2 * L * (1.5 * (1 - nu) * EI * eps * kappa**2 + EA * eps**3 / 2)
    assert odd == pytest.approx(expected, rel=1e-9)
