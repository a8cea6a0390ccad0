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
