"""The iterative nonlinear Castigliano chain-algorithm solver (thesis section 6.2.1).

How the thesis' method maps onto the code:

* eqs 80-82: each compliant member's tip deflections (dx, dy) and rotation under tip forces
  N, V and moment M, from Castigliano's theorem with bending, axial and shear terms (shear
  form factor 6/5 of a rectangle, G = E / 2(1 + nu)). That is the member's flexibility
  matrix (:func:`cantilever_flexibility`); its inverse, written in the member's chord frame,
  is the member stiffness (:func:`natural_stiffness`).
* eqs 83-84: member tips are chained: each member's tip position is its root plus its chord
  rotated by the accumulated rotations, i.e. the geometry is updated with large rotations.
  Here every member is followed in its own rotating (co-rotational) chord frame, so the
  chained tip positions are exact for any rotation.
* eqs 85-86: equilibrium at every joint plus loop closure of the chains form one square
  system. Rigid plates and blocks are merged into rigid bodies with three unknowns each, and
  the system is solved for joint displacements (the displacement form of the same equations).
* Each member's axis is longer than its chord when it bends (the shallow-arch "bowing"
  term, L (2 t_a^2 - t_a t_b + 2 t_b^2) / 30 for the cubic shape): this couples axial force
  and bending inside the member, to first order in the axial force N; the N^2 term of the
  stability functions is carried too (a compressed knee hinge reaches N L^2 / EI = -4.8 by
  1 mm next to the toggle, where the first-order term alone is about 1.4 % too stiff). So one
  element per hinge or link is enough (checked within 0.3 % against an independent
  32-segment geometrically exact frame model on the presets; at 1 mm next to the toggle,
  within about 0.1 point of k_out of the same model split into 8 on toggle-band-0 and the
  10 and 15 N design answers, 0.3 on like-4 of the continuum table, whose oblique roots put the
  hinge's centroid e off its chord: the section's moment is then a + b s + N (w + e), and
  the second-order term carries e too (profile_bowing's d1, d2; like-4's A against the frame
  model at 1 mm -0.80 -> -0.39 %; one-off runs). Splitting every hinge in two costs 41 % of
  a batch solve (stop 57, one-off).
* The material is St Venant-Kirchhoff's, the continuum reference's: past Hooke's law each
  member's energy carries the law's cubic term in its section strains,
  3/2 (1 - nu) EI eps kappa^2 + EA eps^3 / 2 a length (:func:`material_coefficients`). It
  counts only at strains of a few percent: next to the toggle by 1 mm (like-4 of the
  continuum table: A -1.84 -> -1.04 % against the continuum at 1 mm).
* Figure 47: the load is applied in increments and the geometry updated after each; the
  run stops when the output port reaches the target travel (the increments are taken in
  output travel, so the target is met exactly) or the input force reaches a target. Newton
  equilibrium corrections at every increment remove the drift of a purely incremental
  scheme, so the answer does not depend on the increment size. Every increment's state is
  checked for stability (a negative mode of the tangent stiffness under the dead input
  load is reported, not followed).

Many designs of the same topology (a sweep row) are solved together: the per-design
arrays carry a leading batch axis, and each design's Newton iterations run on their own in
the compiled kernel (:mod:`sensor.mechanics._solver_kernel`: the member formulas above, dense
assembly on the bodies' dofs, and Gaussian elimination with partial pivoting that skips the
zeros of the banded stiffness matrix). Units: mm, N, MPa, mJ (N mm).
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np
from scipy.integrate import simpson

from geometry.topology import BeamModel
from sensor.errors import (
    ConvergenceError,
    InstabilityError,
    SensorInputError,
    SingularSystemError,
    SnapThroughError,
    UnreachableTargetError,
)
from sensor.mechanics import _solver_kernel as _kernel

SHEAR_FORM_FACTOR = 6.0 / 5.0  # rectangle, in the shear term of eqs 80-81
#: Output travel (fraction of the target) of the beam model's linear-limit solve (``dacm solve
#: --linear``, the continuum comparisons' linear limit).
LINEAR_LIMIT_FRACTION = 1e-3


# --- member stiffness from Castigliano (eqs 80-82) -----------------------------------------

def cantilever_flexibility(L, t, b, E, G):
    """Tip flexibility of a cantilever of length L, section t x b (mm), moduli E, G (MPa).

    Returns C (..., 3, 3) with [dx, dy, dtheta] = C [N, V, M] in the member frame: the
    integrals of eqs 80-82 for tip loads (bending M(s) = M + V (L - s), axial N, shear V).
    """
    L, t, b, E, G = np.broadcast_arrays(*(np.asarray(v, dtype=float) for v in (L, t, b, E, G)))
    A = t * b
    EI = E * b * t**3 / 12.0
    C = np.zeros(L.shape + (3, 3))
    C[..., 0, 0] = L / (E * A)
    C[..., 1, 1] = L**3 / (3 * EI) + SHEAR_FORM_FACTOR * L / (G * A)
    C[..., 1, 2] = C[..., 2, 1] = L**2 / (2 * EI)
    C[..., 2, 2] = L / EI
    return C


#: Gauss-Legendre points and weights on [0, 1] for the profile integrals (3 points a
#: segment: exact for the cubic-in-s integrands of a uniform segment, and within 1e-6 on
#: the fillet segments, whose thickness changes by a few percent from station to station).
_GAUSS_X, _GAUSS_W = ((np.polynomial.legendre.leggauss(3)[0] + 1) / 2, np.polynomial.legendre.leggauss(3)[1] / 2)


def _profile_integrals(stations) -> np.ndarray:
    """(..., 11): int ds/t, int ds/t^3, int (L-s) ds/t^3, int (L-s)^2 ds/t^3, int e^2 ds/t^3,
    int e (L-s) ds/t^3, int e ds/t^3, and the material law's int phi_a^2 ds/t^4,
    int phi_a phi_b ds/t^4, int phi_b^2 ds/t^4 and int ds/t^2 (phi_a = (L-s)/L,
    phi_b = s/L; mm powers) under the stations (..., k, 2 or 3) of s, t and, if given, e
    (all linear between stations; 3-point Gauss on each segment)."""
    st = np.asarray(stations, dtype=float)
    s, t = st[..., 0], st[..., 1]
    h = np.diff(s, axis=-1)[..., None]                                 # (..., k-1, 1)
    sq = s[..., :-1, None] + h * _GAUSS_X                              # (..., k-1, 3)
    tq = t[..., :-1, None] + np.diff(t, axis=-1)[..., None] * _GAUSS_X
    w = (h * _GAUSS_W).reshape(*h.shape[:-2], -1)                      # (..., 3 (k-1))
    arm = (s[..., -1:] - sq.reshape(*sq.shape[:-2], -1))               # L - s
    inv_t = 1.0 / tq.reshape(*tq.shape[:-2], -1)
    w3 = w * inv_t**3
    out = np.zeros(s.shape[:-1] + (11,))
    out[..., 0] = (w * inv_t).sum(-1)
    out[..., 1] = w3.sum(-1)
    out[..., 2] = (w3 * arm).sum(-1)
    out[..., 3] = (w3 * arm * arm).sum(-1)
    if st.shape[-1] > 2:
        e = st[..., 2]
        eq = (e[..., :-1, None] + np.diff(e, axis=-1)[..., None] * _GAUSS_X).reshape(inv_t.shape)
        out[..., 4] = (w3 * eq * eq).sum(-1)
        out[..., 5] = (w3 * eq * arm).sum(-1)
        out[..., 6] = (w3 * eq).sum(-1)
    phi_a = arm / s[..., -1:]
    w4 = w3 * inv_t
    out[..., 7] = (w4 * phi_a * phi_a).sum(-1)
    out[..., 8] = (w4 * phi_a * (1 - phi_a)).sum(-1)
    out[..., 9] = (w4 * (1 - phi_a) ** 2).sum(-1)
    out[..., 10] = (w * inv_t * inv_t).sum(-1)
    return out


def profile_flexibility(stations, b, E, G):
    """Tip flexibility (..., 3, 3) of a cantilever whose in-plane thickness varies along it:
    the integrals of eqs 80-82 with the section's A(s) = t(s) b and I(s) = b t(s)^3 / 12
    under the stations (..., k, 2) of s and t (mm; t linear between stations, the member's
    length the last s):

        C_NN = int ds / (E A),   C_VV = int (L - s)^2 ds / (E I) + 6/5 int ds / (G A),
        C_VM = int (L - s) ds / (E I),   C_MM = int ds / (E I).

    With a third column e (mm, linear between stations), the section's centroid lies e to
    the left of the axis, where the tip's loads act: the section's moment is
    M + V (L - s) + N e, which adds C_NN += int e^2 ds / (E I), C_NV = int e (L - s) ds / (E I)
    and C_NM = int e ds / (E I) (the same energy integrals, Castigliano's second theorem).

    A flexibility-based element: exact, up to the quadrature, for any EI(s), EA(s) and e(s);
    for a uniform member it equals :func:`cantilever_flexibility`.
    """
    return _flexibility_of(_profile_integrals(stations), b, E, G)


def _flexibility_of(q, b, E, G, scale=1.0):
    """Tip flexibility (..., 3, 3) from the section integrals q (..., 7 or more) of
    :func:`_profile_integrals` (see :func:`profile_flexibility`), of the member stretched
    ``scale`` times along its length (an integral of (L - s)^k ds grows as scale^(k + 1))."""
    b, E, G = (np.asarray(v, dtype=float) for v in (b, E, G))
    bending = 12.0 / (E * b)
    C = np.zeros(q.shape[:-1] + (3, 3))
    C[..., 0, 0] = scale * (q[..., 0] / (E * b) + bending * q[..., 4])
    C[..., 1, 1] = bending * scale**3 * q[..., 3] + SHEAR_FORM_FACTOR * scale * q[..., 0] / (G * b)
    C[..., 1, 2] = C[..., 2, 1] = bending * scale**2 * q[..., 2]
    C[..., 2, 2] = bending * scale * q[..., 1]
    C[..., 0, 1] = C[..., 1, 0] = bending * scale**2 * q[..., 5]
    C[..., 0, 2] = C[..., 2, 0] = bending * scale * q[..., 6]
    return C


def material_coefficients(q, b, E, nu, scale=1.0):
    """(..., 4) coefficients s11, s12, s22 (1 / N^2 mm) and s00 (mm / N^2) of the material
    law's cubic strain energy of a member, n (s11 M_a^2 + s12 M_a M_b + s22 M_b^2 + s00 n^2),
    from its four material integrals q (..., 4): int phi_a^2 ds/t^4, int phi_a phi_b ds/t^4,
    int phi_b^2 ds/t^4 and int ds/t^2 (the last four of :func:`_profile_integrals`; the
    member stretched ``scale`` times along its length).

    The continuum reference (:mod:`sensor.mechanics.continuum`) is St Venant-Kirchhoff's:
    energy E / 2 E11^2 a volume in a plane-stress fibre, E11 = e + e^2 / 2 its Green strain,
    e its stretch. In a section of axial strain eps and curvature kappa, the fibre y from the
    centroid stretches e = eps - kappa y_d, where y_d = y - nu (eps y - kappa y^2 / 2) is
    where the section's contraction (nu e, plane stress) puts it. To the first order past
    Hooke's law the section's energy a length gains
    3/2 (1 - nu) EI eps kappa^2 + EA eps^3 / 2 (the cubic terms of the expansion; checked
    against a plane-stress strip of the continuum's law in
    tests/mechanics/test_material_law.py). With eps = N / (E A(s)) and kappa = M(s) / (E I(s)),
    M(s) = -M_a phi_a + M_b phi_b along the member, the coefficients are its integrals:
    s11 = 18 (1 - nu) / (E b)^2 int phi_a^2 ds / t^4, s12 = -2 x that with phi_a phi_b,
    s22 with phi_b^2, and s00 = int ds / t^2 / (2 (E b)^2). Next to the toggle, a hinge
    bent to 3-4 % strain at 1 mm, they move A by up to 1 % (like-4 of the continuum table).
    """
    b, E, nu = (np.asarray(v, dtype=float) for v in (b, E, nu))
    bend = 18.0 * (1 - nu) / (E * b) ** 2 * scale
    return np.stack([bend * q[..., 0], -2 * bend * q[..., 1], bend * q[..., 2],
                     q[..., 3] * scale / (2 * (E * b) ** 2)], axis=-1)


#: Sub-intervals per profile segment in the bowing integrals: midpoint rules with 16 and 32,
#: whose errors go as the square of the step, combined by Richardson's extrapolation.
_BOW_SUBSTEPS = 16


def profile_bowing(stations):
    """Bowing and second-order coefficients (..., 8) of members whose thickness varies along
    them, from the deflected shape under end moments (curvature M(s) / EI(s) with M linear in
    s, eqs 80-82), so a neck between stiff fillets bends where it is thin:

    * p11, p12, p22 (mm): the axis is longer than the chord by
      p11 theta_a^2 + p12 theta_a theta_b + p22 theta_b^2 when the ends turn by theta_a,
      theta_b from the chord (the shallow-arch term of the solver's co-rotational members;
      for a uniform member L (2, -1, 2) / 30, the cubic shape's);
    * c11, c12, c22 (dimensionless; times 12 / (E b), mm/N): the axial force N's second-order
      term in the bending energy, N^2 (c11 theta_a^2 + c12 theta_a theta_b + c22 theta_b^2):
      c11 = -1/2 int m_a^2 ds / EI, c12 = -int m_a m_b ds / EI, c22 = -1/2 int m_b^2 ds / EI,
      where m_a, m_b are the deflections w under unit end rotations less their (1 / EI)-
      weighted projections onto a + b s: the moments of the first-order change of the shape
      under N (the beam-column of Timoshenko & Gere, Theory of Elastic Stability, 1.9); for
      a uniform member -L^3 (11, -13, 11) / 12600 EI, the N^2 term of the stability
      functions' series;
    * d1, d2 (dimensionless; times 12 / (E b), mm/N): where the stations carry a third column, the
      centroid offset e (:func:`profile_flexibility`; an oblique root's centroid leaves the
      chord), the section's moment is a + b s + N (w + e), and the second-order energy gains
      N^2 (d1 theta_a + d2 theta_b): d1 = -int m_a r_e ds / EI, d2 = -int m_b r_e ds / EI,
      r_e being e less its (1 / EI)-weighted projection onto a + b s. Zero without e.
    """
    coarse, fine = (_bowing_integrals(stations, n) for n in (_BOW_SUBSTEPS, 2 * _BOW_SUBSTEPS))
    return (4 * fine - coarse) / 3


def _bowing_integrals(stations, substeps):
    """:func:`profile_bowing`'s eight integrals by the midpoint rule, ``substeps`` a segment."""
    st = np.asarray(stations, dtype=float)
    s, t = st[..., 0], st[..., 1]
    L = s[..., -1:]
    frac = (np.arange(substeps) + 0.5) / substeps

    def midpoints(v):  # v (linear between stations) at every sub-interval's midpoint
        return (v[..., :-1, None] + np.diff(v, axis=-1)[..., None] * frac).reshape(*v.shape[:-1], -1)

    x, tx = midpoints(s), midpoints(t)
    ds = np.repeat(np.diff(s, axis=-1) / substeps, substeps, axis=-1)
    flex = ds / tx**3                                       # ds / EI, up to E b / 12
    fa, fb = (1 - x / L) * flex, (x / L) * flex            # curvature per unit end moment
    cum_a, cum_b = np.cumsum(fa, -1) - fa / 2, np.cumsum(fb, -1) - fb / 2
    Aa, Ab = fa.sum(-1), fb.sum(-1)
    Ca, Cb = ((L - x) * fa).sum(-1), ((L - x) * fb).sum(-1)
    det = Aa * Cb - Ab * Ca
    Lr = L[..., 0]

    def slope(theta_a, theta_b):  # w'(x) for unit end rotations: w(0) = w(L) = 0
        r1, r2 = theta_b - theta_a, -theta_a * Lr
        ma, mb = (r1 * Cb - Ab * r2) / det, (Aa * r2 - Ca * r1) / det
        return theta_a + ma[..., None] * cum_a + mb[..., None] * cum_b

    f0, f1, f2 = flex.sum(-1), (flex * x).sum(-1), (flex * x * x).sum(-1)
    gram = f0 * f2 - f1 * f1

    def residual_moment(w):  # w less its flex-weighted projection onto a + b x
        r0, r1 = (flex * w).sum(-1), (flex * w * x).sum(-1)
        a, b = (r0 * f2 - r1 * f1) / gram, (f0 * r1 - f1 * r0) / gram
        return w - a[..., None] - b[..., None] * x

    pa, pb = slope(1.0, 0.0), slope(0.0, 1.0)
    ma, mb = (residual_moment(np.cumsum(p * ds, -1) - p * ds / 2) for p in (pa, pb))
    re = residual_moment(midpoints(st[..., 2])) if st.shape[-1] > 2 else 0.0  # N e's arm
    return np.stack([0.5 * (pa * pa * ds).sum(-1), (pa * pb * ds).sum(-1), 0.5 * (pb * pb * ds).sum(-1),
                     -0.5 * (ma * ma * flex).sum(-1), -(ma * mb * flex).sum(-1), -0.5 * (mb * mb * flex).sum(-1),
                     -(ma * re * flex).sum(-1), -(mb * re * flex).sum(-1)], axis=-1)


def natural_stiffness(L, t, b, E, G, flexibility=None):
    """Member stiffness (..., 3, 3) on the chord-frame deformations [u, theta_a, theta_b].

    u is the chord's stretch, theta_a and theta_b the end rotations relative to the chord.
    A cantilever clamped at a has tip deflection v = -L theta_a and tip rotation
    theta_b - theta_a, so K = T^T C^-1 T with T mapping [u, theta_a, theta_b] to [dx, v, theta].
    ``flexibility`` replaces the uniform member's C (:func:`profile_flexibility`).
    """
    C = cantilever_flexibility(L, t, b, E, G) if flexibility is None else flexibility
    K = np.linalg.inv(C)
    L = np.asarray(L, dtype=float)
    T = np.zeros(L.shape + (3, 3))
    T[..., 0, 0] = 1.0
    T[..., 1, 1] = -L
    T[..., 2, 1] = -1.0
    T[..., 2, 2] = 1.0
    return np.swapaxes(T, -1, -2) @ K @ T


# --- topology: rigid bodies and dofs -------------------------------------------------------

@dataclass(frozen=True, eq=False)
class Topology:
    """What a batch of designs with the same connectivity shares."""

    n_nodes: int
    body_of_node: np.ndarray      # (n,) rigid-body (cluster) index of each node
    master_of_body: np.ndarray    # (c,) the node whose position and rotation a body carries
    free_body: np.ndarray         # (c,) False for bodies held by a support
    dof_of_body: np.ndarray       # (c, 3) reduced dof index, -1 if fixed
    n_dof: int
    flex: np.ndarray              # (e,) member indices of the compliant members
    ea: np.ndarray                # (e,) start node
    eb: np.ndarray                # (e,) end node
    elem_dofs: np.ndarray         # (e, 6) reduced dof indices (-1 fixed) of the element ends
    input_node: int
    output_node: int
    band: tuple                   # stiffness envelope: first and last column of each row,
                                  # and the last row each column can reach (see _envelope)

    @property
    def kernel_args(self) -> tuple:
        """The connectivity as the compiled kernel takes it."""
        return (self.body_of_node, self.dof_of_body, self.ea, self.eb, self.elem_dofs,
                self.input_node, self.output_node, *self.band)


def _bodies(model: BeamModel) -> tuple[np.ndarray, np.ndarray]:
    """Union the nodes joined by rigid members into rigid bodies."""
    parent = list(range(len(model.nodes)))

    def find(i):
        while parent[i] != i:
            parent[i] = parent[parent[i]]
            i = parent[i]
        return i

    for kind, (a, b) in zip(model.member_kind, model.member_nodes):
        if kind == "rigid":
            ra, rb = find(int(a)), find(int(b))
            parent[max(ra, rb)] = min(ra, rb)
    roots = np.array([find(i) for i in range(len(parent))])
    masters, body = np.unique(roots, return_inverse=True)
    return body, masters


def prepare(model: BeamModel) -> Topology:
    """Rigid bodies and dof numbering of a model's connectivity (cached: a sweep's designs
    share a handful of connectivities)."""
    key = (len(model.nodes), model.member_nodes.tobytes(), model.member_kind, model.supports,
           model.input_node, model.output_node)
    topo = _TOPOLOGIES.get(key)
    if topo is None:
        if len(_TOPOLOGIES) > 64:
            _TOPOLOGIES.clear()
        topo = _TOPOLOGIES[key] = _prepare(model)
    return topo


_TOPOLOGIES: dict = {}


def _prepare(model: BeamModel) -> Topology:
    body, masters = _bodies(model)
    nb = len(masters)
    fixed = np.zeros((nb, 3), dtype=bool)
    for node, dofs in model.supports:
        c = body[node]
        if len(body[body == c]) > 1 and set(dofs) != {"x", "y", "rz"}:
            if node != masters[c]:
                raise SingularSystemError(
                    f"support at node {node} fixes only {dofs} on a rigid body: clamp it or "
                    "put the support on the body's first node")
        for dof in dofs:
            fixed[c, ["x", "y", "rz"].index(dof)] = True
    # a body with all three dofs fixed is held; partially held bodies keep their free dofs.
    # Dofs are numbered body by body in reverse Cuthill-McKee order of the bodies' coupling
    # graph: the stiffness matrix is then banded, which the kernel's elimination exploits.
    flex = np.array([i for i, k in enumerate(model.member_kind) if k != "rigid"], dtype=int)
    if len(flex) == 0:
        raise SingularSystemError("the model has no compliant member")
    ea, eb = model.member_nodes[flex, 0], model.member_nodes[flex, 1]
    order = _band_order(nb, body[ea], body[eb])
    free = ~fixed[order]
    dof_of_body = np.empty((nb, 3), dtype=np.int64)
    dof_of_body[order] = np.where(free, np.cumsum(free).reshape(nb, 3) - 1, -1)
    elem_dofs = np.concatenate([dof_of_body[body[ea]], dof_of_body[body[eb]]], axis=1)
    return Topology(len(model.nodes), body.astype(np.int64), masters, ~fixed.all(1), dof_of_body,
                    int(free.sum()), flex, ea.astype(np.int64), eb.astype(np.int64), elem_dofs,
                    int(model.input_node), int(model.output_node), _envelope(elem_dofs, int(free.sum())))


def _envelope(elem_dofs: np.ndarray, n_dof: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Where the stiffness matrix can be nonzero (the members couple their end dofs): per
    row the first and last column, and per column the last row that elimination with row
    exchanges can reach (the running maximum of the columns' last rows)."""
    pattern = np.eye(n_dof, dtype=bool)
    for dofs in elem_dofs:
        d = dofs[dofs >= 0]
        pattern[np.ix_(d, d)] = True
    start = np.argmax(pattern, axis=1)
    end = n_dof - 1 - np.argmax(pattern[:, ::-1], axis=1)
    return start.astype(np.int64), end.astype(np.int64), np.maximum.accumulate(end).astype(np.int64)


def _band_order(n_bodies: int, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """The bodies in reverse Cuthill-McKee order of their coupling by members a-b."""
    import scipy.sparse as sp
    from scipy.sparse.csgraph import reverse_cuthill_mckee

    pairs = np.concatenate([a, b]), np.concatenate([b, a])
    graph = sp.csr_matrix((np.ones(2 * len(a)), pairs), shape=(n_bodies, n_bodies))
    return reverse_cuthill_mckee(graph, symmetric_mode=True)


# --- the state of a batch ----------------------------------------------------------------

@dataclass(frozen=True, eq=False)
class _Batch:
    """Per-design constants of a batch: undeformed geometry and member stiffnesses."""

    X: np.ndarray        # (B, n, 2) undeformed node positions
    r0: np.ndarray       # (B, n, 2) node offsets from their body's master node
    d0: np.ndarray       # (B, e, 2) undeformed member chords
    L0: np.ndarray       # (B, e) undeformed member lengths
    beta0: np.ndarray    # (B, e) undeformed chord angles
    Kn: np.ndarray       # (B, e, 3, 3) natural member stiffness
    f_in: np.ndarray     # (B, 2) unit input force direction
    d_out: np.ndarray    # (B, 2) output travel direction
    d_in: np.ndarray     # (B, 2)
    dof_weight: np.ndarray  # (B, n_dof) 1 on forces, 1 / model size on moments (residual norm)
    bow: np.ndarray      # (B, e, 12) bowing and second-order coefficients (profile_bowing),
                         # then the material law's (material_coefficients)

    @property
    def kernel_args(self) -> tuple:
        """The per-design constants as the compiled kernel takes them (C-ordered float arrays)."""
        return tuple(np.ascontiguousarray(a, dtype=float)
                     for a in (self.r0, self.d0, self.L0, self.beta0, self.Kn, self.f_in, self.d_out, self.bow))


def _make_batch(topo: Topology, models: list[BeamModel]) -> _Batch:
    X = np.stack([m.nodes for m in models])
    r0 = X - X[:, topo.master_of_body[topo.body_of_node]]
    d = X[:, topo.eb] - X[:, topo.ea]
    L0 = np.linalg.norm(d, axis=-1)
    beta0 = np.arctan2(d[..., 1], d[..., 0])
    t = np.stack([m.thickness_mm[topo.flex] for m in models])
    b = np.stack([m.depth_mm[topo.flex] for m in models])
    E = np.array([m.E_MPa for m in models])[:, None]
    nu = np.array([m.nu for m in models])[:, None]
    G = E / (2 * (1 + nu))
    C, bow = _member_sections(topo, models, L0, t, b, E, G, nu)
    Kn = natural_stiffness(L0, t, b, E, G, C)
    f_in = np.stack([m.input_direction for m in models])
    d_out = np.stack([m.output_direction for m in models])
    size = np.ptp(X, axis=1).max(axis=1)              # (B,) largest extent, mm
    weight = np.ones((len(models), topo.n_dof))
    rot = topo.dof_of_body[:, 2][topo.dof_of_body[:, 2] >= 0]
    weight[:, rot] = 1.0 / size[:, None]
    return _Batch(X, r0, d, L0, beta0, Kn, f_in, d_out, f_in, weight, bow)


def _member_sections(topo: Topology, models: list[BeamModel], L0, t, b, E, G, nu):
    """Tip flexibility (B, e, 3, 3), and bowing, second-order and material coefficients
    (B, e, 12) of the compliant members: uniform ones in closed form, those with a thickness
    profile (hinges with root fillets) from :func:`_profile_integrals`,
    :func:`profile_bowing` and :func:`material_coefficients`, all of a batch in one call.
    The profiles of one member stack across the batch; their stations are scaled to the
    member's undeformed length."""
    C = cantilever_flexibility(L0, t, b, E, G)
    EI = E * b * t**3 / 12.0
    # a uniform member's material integrals (see material_coefficients)
    uniform = L0[..., None] * np.array([1 / 3, 1 / 6, 1 / 3, 1.0]) / t[..., None] ** np.array([4, 4, 4, 2])
    bow = np.concatenate([L0[..., None] * np.array([2.0, -1.0, 2.0]) / 30.0,
                          -(L0**3 / EI)[..., None] * np.array([11.0, -13.0, 11.0]) / 12600.0,
                          np.zeros(L0.shape + (2,)),
                          material_coefficients(uniform, b, E, nu)], axis=-1)
    first = models[0].profile_mm
    cols = [j for j, k in enumerate(topo.flex) if first[k] is not None]
    if cols:
        _profiled_sections(topo.flex[cols], cols, models, L0, b, E, G, nu, C, bow)
    # the hinges' axial compliance beyond their profiles' (geometry.topology.axial_spread)
    C[..., 0, 0] += np.stack([m.axial_spread[topo.flex] for m in models]) / (E * b)
    return C, bow


def _profiled_sections(members, cols, models, L0, b, E, G, nu, C, bow) -> None:
    """Fill in the flexibility C and the coefficients ``bow`` (see :func:`_member_sections`)
    of the members with a thickness profile (model indices ``members``, batch columns
    ``cols``)."""
    # the integrals depend on the profile alone (a sweep's cells share a few): each distinct
    # profile is integrated once, then scaled by each design's E, G and depth
    per = _profile_sections([m.profile_mm[k] for m in models for k in members]).reshape(len(models), len(members), _N_SECTION)
    scale = (L0[:, cols] / np.array([[m.profile_mm[k][-1, 0] for k in members] for m in models]))
    q = per[..., [0, 1, 2, 3, 7, 8, 9, 15, 16, 17, 18]]  # _profile_integrals' order
    C[:, cols] = _flexibility_of(q, b[:, cols], E, G, scale)
    bow[:, cols, :3] = per[..., 4:7] * scale[..., None]
    bow[:, cols, 3:6] = per[..., 10:13] * (12.0 / (E * b[:, cols]) * scale**3)[..., None]
    bow[:, cols, 6:8] = per[..., 13:15] * (12.0 / (E * b[:, cols]) * scale**2)[..., None]
    bow[:, cols, 8:] = material_coefficients(q[..., 7:], b[:, cols], E, nu, scale)


_SECTIONS: dict = {}
_N_SECTION = 19


def _profile_sections(profiles: list[np.ndarray]) -> np.ndarray:
    """(n, 19): for each thickness profile (mm), (int ds/t, int ds/t^3, int (L-s) ds/t^3,
    int (L-s)^2 ds/t^3, bowing p11, p12, p22, int e^2 ds/t^3, int e (L-s) ds/t^3,
    int e ds/t^3, second-order c11, c12, c22, d1, d2, and the material law's four
    integrals) of :func:`_profile_integrals` and :func:`profile_bowing`, cached by its
    shape and bytes; the profiles not cached yet
    (every part of a Monte Carlo draw is new) are integrated together, one batch per shape
    of their station arrays."""
    if len(_SECTIONS) > 100_000:
        _SECTIONS.clear()
    keys = [(p.shape, p.tobytes()) for p in profiles]
    new: dict[tuple, dict[bytes, np.ndarray]] = {}
    for key, p in zip(keys, profiles):
        if key not in _SECTIONS:
            new.setdefault(p.shape, {})[key] = p
    for group in new.values():
        st = np.array(list(group.values()))
        q = _profile_integrals(st)
        with np.errstate(invalid="ignore", divide="ignore"):  # zero-length segments
            bow = np.nan_to_num(profile_bowing(st))
        rows = np.column_stack([q[:, :4], bow[:, :3], q[:, 4:7], bow[:, 3:], q[:, 7:]])
        _SECTIONS.update(zip(group, rows))
    return np.array([_SECTIONS[k] for k in keys]).reshape(len(keys), _N_SECTION)


# --- results ---------------------------------------------------------------------------------

@dataclass(frozen=True, eq=False)
class SolveResult:
    """The solved state of one design (mm, N, mJ).

    ``force_N``, ``input_mm`` and ``output_mm`` are the force-deflection curves of the input
    and output ports, one point per increment (starting at zero). ``member_forces`` holds,
    per compliant member, the axial force N (N) and the end moments M_a, M_b (N mm);
    ``hinge_rotation_deg`` the bending of each hinge (end rotation b minus a), keyed by
    thesis hinge number.
    """

    amplification: float          # A = output travel / input travel
    k_out_N_per_mm: float         # input force / output travel
    strain_energy_mJ: float       # total strain energy in the final state
    input_force_N: float
    input_travel_mm: float
    output_travel_mm: float
    force_N: np.ndarray
    input_mm: np.ndarray
    output_mm: np.ndarray
    work_mJ: float                # work of the input force along the load path (Simpson)
    hinge_rotation_deg: dict
    member_forces: np.ndarray     # (e, 3): N, M_a, M_b
    member_strain_energy_mJ: np.ndarray  # (e,) strain energy of each compliant member
    member_index: np.ndarray      # (e,) model member index of each row of member_forces
    deformed_nodes: np.ndarray    # (n, 2)
    node_rotation_rad: np.ndarray  # (n,)
    increments: int
    residual: float               # final relative equilibrium residual
    converged: bool

    @property
    def sensitivity_mm_per_N(self) -> float:
        """Output travel per input force, mm/N (the inverse of k_out)."""
        return 1.0 / self.k_out_N_per_mm


def scaled_result(r: SolveResult, factor: float) -> SolveResult:
    """A linear-limit result scaled by ``factor``: forces, travels, member forces and hinge
    rotations times it, strain energies and work times its square; A and k_out are the
    linear limit's. ``deformed_nodes`` and ``node_rotation_rad`` stay the small-travel
    state's (the solved shape, not an extrapolated one)."""
    return dataclasses.replace(
        r, input_force_N=r.input_force_N * factor, input_travel_mm=r.input_travel_mm * factor,
        output_travel_mm=r.output_travel_mm * factor, force_N=r.force_N * factor,
        input_mm=r.input_mm * factor, output_mm=r.output_mm * factor,
        strain_energy_mJ=r.strain_energy_mJ * factor**2, work_mJ=r.work_mJ * factor**2,
        member_forces=r.member_forces * factor, member_strain_energy_mJ=r.member_strain_energy_mJ * factor**2,
        hinge_rotation_deg={k: v * factor for k, v in r.hinge_rotation_deg.items()})


@dataclass(frozen=True)
class SolverOptions:
    """Increments, tolerances and limits of a solve."""

    increments: int = 4
    tol: float = 1e-9               # relative residual |r| / |F_ext| (or stalled below sqrt(tol))
    max_iterations: int = 25
    max_bisections: int = 4
    max_force_N: float = 1e4        # beyond this the target is deemed unreachable


def solve(model: BeamModel, target_output_mm: float | None = None, target_force_N: float | None = None,
          options: SolverOptions = SolverOptions()) -> SolveResult:
    """Solve one beam model to an output travel (1 mm if neither target is given) or an
    input force.

    Raises a :class:`SolverError` subclass when the solve fails; never returns a result
    that is not converged.
    """
    results, errors = solve_batch([model], target_output_mm, target_force_N, options)
    if errors[0] is not None:
        raise errors[0]
    return results[0]


def solve_batch(models: list[BeamModel], target_output_mm: float | None = None,
                target_force_N: float | None = None, options: SolverOptions = SolverOptions()):
    """Solve many models of one connectivity together.

    Returns (results, errors): per model a :class:`SolveResult` or None, and None or the
    :class:`SolverError` that stopped it (two empty lists for no model).
    """
    if target_output_mm is None and target_force_N is None:
        target_output_mm = 1.0
    if target_output_mm is not None and target_force_N is not None:
        raise SensorInputError("give one of target_output_mm and target_force_N, not both")
    target = target_output_mm if target_force_N is None else target_force_N
    if not (np.isfinite(target) and target > 0):
        name = "target_output_mm" if target_force_N is None else "target_force_N"
        raise SensorInputError(f"{name} = {target!r}: must be a positive finite number")
    if not models:
        return [], []
    topo = prepare(models[0])
    for m in models[1:]:
        if m.member_nodes.shape != models[0].member_nodes.shape or not np.array_equal(
                m.member_nodes, models[0].member_nodes) or m.member_kind != models[0].member_kind:
            raise SensorInputError("solve_batch needs models of one connectivity")
    bt = _make_batch(topo, models)
    disp = target_force_N is None
    run = _Run(topo, bt, models, options, displacement_control=disp, target=target)
    results, errors = run.run()
    for b in run.deferred:
        alone = _Run(topo, _make_batch(topo, [models[b]]), [models[b]], options,
                     displacement_control=disp, target=target).run()
        results[b], errors[b] = alone[0][0], alone[1][0]
    return results, errors


class _Run:
    """One incremental-iterative run of a batch (Figure 47, with Newton corrections)."""

    def __init__(self, topo, bt, models, options, displacement_control, target):
        self.topo, self.bt, self.models, self.o = topo, bt, models, options
        self.disp = displacement_control
        self.target = target
        self.B = len(models)
        self.deferred: list[int] = []   # designs set aside to be solved alone
        self.work = _kernel.work(topo.n_nodes, topo.n_dof)
        self.bt_args = bt.kernel_args

    def run(self):
        topo, B, o = self.topo, self.B, self.o
        nb = len(topo.master_of_body)
        q = np.zeros((B, nb, 3))
        lam = np.zeros(B)
        errors: list = [None] * B
        alive = np.ones(B, dtype=bool)
        hist_F, hist_in, hist_out = [np.zeros(B)], [np.zeros(B)], [np.zeros(B)]
        step = 1.0 / o.increments
        level = 0.0
        lam_scale = np.ones(B)  # a force scale for the residual norm, from the first step
        prev = None
        residual = np.zeros(B)
        n_inc = 0
        while level < 1.0 - 1e-12 and alive.any():
            new_level = min(1.0, level + step)
            goal = new_level * self.target
            # predictor: secant extrapolation from the last two converged states
            if prev is not None:
                frac = (new_level - level) / (level - prev[2])
                q_try = q + frac * (q - prev[0])
                lam_try = lam + frac * (lam - prev[1])
            else:
                q_try, lam_try = q.copy(), lam.copy()
            ok, q_new, lam_new, res = self.newton(q_try, lam_try, goal, alive, lam_scale,
                                                  verify=new_level >= 1.0 - 1e-12)
            if not ok[alive].all() and self.B > 1:
                # set the stubborn designs aside: solve_batch re-runs each alone, where
                # halving the step costs only it; the rest go on at this step
                bad = alive & ~ok
                self.deferred.extend(int(b) for b in np.flatnonzero(bad))
                alive &= ~bad
                q_new[bad], lam_new[bad] = q[bad], lam[bad]
                if not alive.any():
                    break
            if not ok[alive].all():
                if step > 1.0 / o.increments / 2**o.max_bisections:
                    step /= 2
                    continue
                bad = alive & ~ok
                for b in np.flatnonzero(bad):
                    errors[b] = ConvergenceError(
                        f"increment {n_inc + 1}: residual {res[b]:.3e} would not fall below "
                        f"{o.tol:g} at input force {lam_new[b]:.4g} N (target {goal:.4g})")
                alive &= ~bad
                if not alive.any():
                    break
            n_inc += 1
            stable, u_in, u_out = self.stable, self.u_in, self.u_out
            for b in np.flatnonzero(alive):
                if self.disp and n_inc == 1 and lam_new[b] <= 0:
                    errors[b] = UnreachableTargetError(
                        f"increment 1: the output moves against its direction (input force "
                        f"{lam_new[b]:.4g} N for output travel {u_out[b]:.4g} mm, residual "
                        f"{res[b]:.2e}): the target cannot be reached by pushing the input")
                    alive[b] = False
                elif self.disp and lam_new[b] <= hist_F[-1][b]:
                    errors[b] = SnapThroughError(
                        f"increment {n_inc}: input force fell from {hist_F[-1][b]:.4g} N to "
                        f"{lam_new[b]:.4g} N while the output travel rose to {u_out[b]:.4g} mm "
                        f"(residual {res[b]:.2e}): limit point, the reading would be ambiguous")
                    alive[b] = False
                elif not stable[b]:
                    errors[b] = InstabilityError(
                        f"increment {n_inc}: the equilibrium at input force {lam_new[b]:.4g} N is "
                        f"unstable (the tangent stiffness has a negative mode; residual {res[b]:.2e}): "
                        "the body would buckle sideways or snap; guide or stiffen it")
                    alive[b] = False
                elif self.disp and abs(lam_new[b]) > o.max_force_N:
                    errors[b] = UnreachableTargetError(
                        f"increment {n_inc}: output travel {u_out[b]:.4g} mm at input force "
                        f"{lam_new[b]:.4g} N (residual {res[b]:.2e}): the target cannot be reached")
                    alive[b] = False
            prev = (q, lam, level)
            q, lam, level = q_new, lam_new, new_level
            residual = np.where(alive, res, residual)
            if n_inc == 1:
                lam_scale = np.maximum(np.abs(lam), 1e-12) / new_level
            hist_F.append(lam.copy()); hist_in.append(u_in); hist_out.append(u_out)
            step = min(step * 2, 1.0 / o.increments)
        return self.collect(q, lam, np.array(hist_F), np.array(hist_in), np.array(hist_out),
                            residual, alive, errors, n_inc)

    def newton(self, q, lam, goal, alive, lam_scale, verify=True):
        """Equilibrium iterations at one increment, each design on its own; returns
        (ok, q, lam, residual) and keeps, per design, whether the last tangent stiffness
        (under the dead input load) is positive definite and both ports' travel.

        Without ``verify`` (intermediate increments) the state is accepted after a correction
        made from a residual below 1e-4: Newton's quadratic convergence leaves about 1e-8,
        and the next increment's iterations start from there.
        The last increment is always verified by evaluating the residual it reports.
        A state is converged when its relative residual is below ``tol``, or stalled at
        round-off (below sqrt(tol) and no longer halving: the condition number of a long
        slender chain limits what the linear solves can reach).
        """
        o, B = self.o, self.B
        q, lam = np.ascontiguousarray(q, dtype=float), np.array(lam, dtype=float)
        status, res = np.zeros(B, dtype=np.int64), np.zeros(B)
        self.stable, self.u_in, self.u_out = np.zeros(B, dtype=bool), np.zeros(B), np.zeros(B)
        _kernel.increment(q, lam, float(goal), float(self.target), np.asarray(lam_scale, dtype=float),
                          alive, verify, self.disp, o.tol, o.max_iterations, self.topo.kernel_args,
                          self.bt_args, self.bt.dof_weight, self.bt.d_in, self.work,
                          status, res, self.stable, self.u_in, self.u_out)
        singular = alive & (status == _kernel.SINGULAR)
        if singular.any() and B == 1:
            raise SingularSystemError(
                f"the system of eqs 85-86 is singular at input force {lam[0]:.4g} N "
                f"(residual {res[0]:.2e}): the model is a mechanism or lacks a support")
        return status == _kernel.CONVERGED, q, lam, res

    def collect(self, q, lam, F, u_in, u_out, residual, alive, errors, n_inc):
        topo, bt = self.topo, self.bt
        u, th = np.zeros(bt.X.shape), np.zeros(bt.X.shape[:2])
        defo, qf, u_member = np.zeros(bt.L0.shape + (3,)), np.zeros(bt.L0.shape + (3,)), np.zeros(bt.L0.shape)
        _kernel.final_state(q, topo.kernel_args, self.bt_args, self.work, u, th, defo, qf, u_member)
        x = bt.X + u
        se = u_member.sum(axis=1)
        work = simpson(F, x=u_in, axis=0)
        bending = np.degrees(defo[..., 2] - defo[..., 1]).tolist()     # (B, e) of each member, deg
        results = []
        for b in range(self.B):
            if not alive[b]:
                results.append(None)
                continue
            m = self.models[b]
            hinge = m.hinge_number[topo.flex]
            rot = {int(h): bending[b][i] for i, h in enumerate(hinge) if h > 0}
            A = u_out[-1, b] / u_in[-1, b]
            results.append(SolveResult(
                amplification=float(A), k_out_N_per_mm=float(lam[b] / u_out[-1, b]),
                strain_energy_mJ=float(se[b]), input_force_N=float(lam[b]),
                input_travel_mm=float(u_in[-1, b]), output_travel_mm=float(u_out[-1, b]),
                force_N=F[:, b].copy(), input_mm=u_in[:, b].copy(), output_mm=u_out[:, b].copy(),
                work_mJ=float(work[b]), hinge_rotation_deg=dict(sorted(rot.items())),
                member_forces=qf[b].copy(), member_strain_energy_mJ=u_member[b].copy(),
                member_index=topo.flex.copy(),
                deformed_nodes=x[b].copy(), node_rotation_rad=th[b].copy(), increments=n_inc,
                residual=float(residual[b]), converged=True))
            if self.disp and u_in[-1, b] <= 0:
                errors[b] = UnreachableTargetError(
                    f"increment {n_inc}: input travel {u_in[-1, b]:.4g} mm is not positive at "
                    f"input force {lam[b]:.4g} N (residual {residual[b]:.2e})")
                results[-1] = None
        return results, errors
