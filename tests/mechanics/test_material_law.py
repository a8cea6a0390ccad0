"""The beam model's material law against the continuum's (DESIGN section 14).

The continuum reference (sensor.mechanics.continuum) is a plane-stress St Venant-Kirchhoff
body. The solver's members carry that law's cubic strain energy in their section strains,
3/2 (1 - nu) EI eps kappa^2 + EA eps^3 / 2 a length (sensor.mechanics.solver.
material_coefficients; the kernel's energy is checked against this form in
tests/mechanics/test_solver_kernel.py). Here the form itself is checked against the
continuum's law: a strip of it, bent to a constant curvature kappa and stretched along the
fibre through its centroid by +-eps, with the continuum's own forms (P2 triangles, total
Lagrangian, Newton)."""

import numpy as np
import pytest
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from sensor.mechanics.continuum import _green_lagrange, _lame, _svk_forms

E, T, L = 1000.0, 1.0, 4.0   # MPa, strip depth and length (mm), unit sheet thickness


def strip_energy(nu: float, eps: float, kappa: float, steps: int = 8) -> float:
    """Strain energy (mJ per mm of sheet) of the strip 0 <= x <= L, |y| <= T / 2 in pure
    bending and stretch: its left face held at x = 0 (free to slide along it, one point held
    at y = 0), its right face's points on the line through the end of the centroid fibre's
    arc (radius (1 + eps) / kappa, turned kappa L), free to slide along that line (exact
    elimination): the faces stay radial and the centroid fibre stretches by eps exactly."""
    from skfem import Basis, ElementTriP2, ElementVector, Functional, MeshTri, asm

    lam, mu = _lame(E, nu, plane_strain=False)
    mesh = MeshTri.init_tensor(np.linspace(0, L, 33), np.linspace(-T / 2, T / 2, 9))
    basis = Basis(mesh, ElementVector(ElementTriP2()))
    tangent, internal = _svk_forms(lam, mu)
    X = basis.doflocs
    left, right = (basis.get_dofs(lambda p, x0=x0: np.isclose(p[0], x0)) for x0 in (0.0, L))
    lx, ly = (np.concatenate([left.nodal[c], left.facet[c]]) for c in ("u^1", "u^2"))
    rx, ry = (np.concatenate([right.nodal[c], right.facet[c]]) for c in ("u^1", "u^2"))
    ry = ry[[int(np.flatnonzero(np.isclose(X[1, ry], X[1, d]))[0]) for d in rx]]  # paired with rx
    held = np.concatenate([lx, ly[np.isclose(X[1, ly], 0.0)]])
    inner = np.setdiff1d(np.arange(basis.N), np.concatenate([held, rx, ry]))
    n_in, n_face = len(inner), len(rx)

    @Functional
    def density(w):
        _, G = _green_lagrange(w["u"].grad)
        return 0.5 * lam * (G[0, 0] + G[1, 1]) ** 2 + mu * np.einsum("ijab,ijab->ab", G, G)

    u = np.zeros(basis.N)
    for step in np.arange(1, steps + 1) / steps:
        a, radius = step * kappa * L, (1 + step * eps) / (step * kappa)
        end = radius * np.array([np.sin(a), 1 - np.cos(a)])
        along = np.array([-np.sin(a), np.cos(a)])
        # the face's points by their position rho along the line: u = T z + offset
        T_map = sp.csr_matrix((np.r_[np.ones(n_in), along[0] * np.ones(n_face), along[1] * np.ones(n_face)],
                               (np.r_[inner, rx, ry], np.r_[np.arange(n_in), n_in + np.arange(n_face), n_in + np.arange(n_face)])),
                              shape=(basis.N, n_in + n_face))
        rho = (X[0, rx] + u[rx] - end[0]) * along[0] + (X[1, ry] + u[ry] - end[1]) * along[1]
        u[rx], u[ry] = end[0] + rho * along[0] - X[0, rx], end[1] + rho * along[1] - X[1, ry]
        for _ in range(30):
            w = basis.interpolate(u)
            r = T_map.T @ asm(internal, basis, u=w)
            if np.linalg.norm(r) < 1e-12 * E * T:
                break
            u += T_map @ spla.spsolve((T_map.T @ asm(tangent, basis, u=w) @ T_map).tocsc(), -r)
        else:
            raise AssertionError(f"strip: Newton did not converge at eps {eps}, kappa {kappa}")
    return float(asm(density, basis, u=basis.interpolate(u)))


@pytest.mark.parametrize("nu", [0.0, 0.35])
def test_section_law_cubic_term_is_the_continuums(nu):
    """The continuum strip's energy odd in eps, less its value at a vanishing curvature (the
    axial eps^3 term), over 2 eps kappa^2 L, against 3/2 (1 - nu) EI at eps 1e-3, kappa 0.015
    /mm (fibre strains up to 0.85 %): within 3 % (measured -1.4 % at nu 0, -1.2 % at 0.35;
    the next terms, of order kappa^2 T^2, grow to -5 to -7 % at kappa 0.03, four times as
    far). Controls: Hooke's law (no cubic term) and St Venant-Kirchhoff's without the
    section's contraction (3/2 EI) are 100 % and 54 % off it at nu 0.35, so the test tells
    them apart; the axial term itself is EA eps^3 / 2 within 0.1 % (measured 0.02 %)."""
    eps, kappa, vanishing = 1e-3, 0.015, 2.5e-5
    odd = {k: strip_energy(nu, eps, k) - strip_energy(nu, -eps, k) for k in (kappa, vanishing)}
    EI, EA = E * T**3 / 12, E * T
    coupling = (odd[kappa] - odd[vanishing]) / (2 * eps * (kappa**2 - vanishing**2) * L)
    assert coupling == pytest.approx(1.5 * (1 - nu) * EI, rel=0.03)
    assert odd[vanishing] == pytest.approx(2 * L * EA * eps**3 / 2, rel=1e-3)
