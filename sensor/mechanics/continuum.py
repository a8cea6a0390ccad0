"""Continuum verification: a 2D finite-element model of a design's cut profile (DESIGN
section 14).

The reference for the beam model (:mod:`sensor.mechanics.solver`): the profile the water
jet leaves (DESIGN section 16: the outline and holes of ``dacm export --dxf`` with every
re-entrant corner rounded with the jet's radius, kerf / 2; by default the design's
``kerf_mm``, 0.8 mm; kerf 0 is the drawing, sharp corners), meshed with gmsh into triangles
refined in the hinges and, finer still, round their root fillets (:func:`_size_function`),
and solved with scikit-fem using quadratic (6-node) triangles, in
plane stress (default) or plane strain.

Boundary conditions follow the beam model (:func:`geometry.topology.build_beam_model`):

* the base plate's bottom edge is clamped (the body stands on it); ``clamp="base plate"``
  clamps the whole base plate instead;
* the input is a rigid punch ``punch_width_mm`` wide (default
  :data:`geometry.topology.INPUT_CONTACT_MM`) at the top plate's centre, pushed straight
  down with no sideways motion or rotation (guided, as the X-stage did);
* the output is the mirror's vertical travel (platform underside centre; the top plate's
  underside for the basis) relative to the fiber tip on the base.

Linear by default; ``nonlinear=True`` solves the geometrically nonlinear problem (total
Lagrangian, St Venant-Kirchhoff: small strains, large rotations) by Newton's method in input
travel increments until the output reaches ``target_output_mm``, and checks that the state
reached is stable (:func:`tangent_negative_modes`: Newton follows the symmetric path
through a sideways bifurcation without noticing). Units: mm, N, MPa, mJ. Needs gmsh and
CadQuery (imported when called).
"""

from __future__ import annotations

import contextlib
import math
from dataclasses import dataclass

import numpy as np
import scipy.sparse.linalg as spla
from numba import njit

from geometry.layout import make_layout, make_parts
from geometry.params import FIELD_RULES, Design, cut_note
from geometry.topology import INPUT_CONTACT_MM, build_beam_model, contact_rule, input_contact_mm, root_radius_mm
from sensor.errors import ConvergenceError, SensorInputError, SolverError
from sensor.mechanics.solver import LINEAR_LIMIT_FRACTION

#: Quadratic elements across each hinge's thickness, per mesh level (the rest of the body
#: scales with it). Consecutive levels differ by sqrt(2) in size, as Richardson needs.
MESH_LEVELS = {"coarse": 3.0, "default": 6.0, "fine": 12.0}
CLAMPS = ("bottom edge", "base plate")
# The punch (its default width geometry.topology.INPUT_CONTACT_MM): the contact the input
# is pushed through. DESIGN section 3's input is a force at the top plate's centre, but a
# point force has no finite travel in plane elasticity (the contact's own compliance grows
# as ln(1 / width)): the reference pushes a 0.5 mm punch
# (geometry.topology.INPUT_CONTACT_MM), and the beam model spreads its input over the same
# contact and takes the top plate's centre-line deflection as the input travel (no contact
# compliance). A depends on the contact where the top plate takes most of the input travel
# (next to the toggle): on 03-03-12-4 (phi2 4 deg), 12 elements across, A is 2.1272 with a
# 0.1 mm punch, 2.1404 with 0.25, 2.1666 with 0.5 and 2.2403 with 1 mm, k_out within 0.2 %
# (a uniform pressure over 0.5 mm gives A within 0.1 % of the punch's: it is the spread,
# not the punch's rigidity). A plain 2 mm plate clamped over a 17.4 mm span (plane strain,
# one run) shows why: under a 0.1 mm punch it is 2.3 % more compliant than under 0.5 mm,
# under 0.05 mm 0.8 % more again (elements of 0.025 mm).


@dataclass(frozen=True, eq=False)
class ContinuumResult:
    """One FE solve, reported at ``output_travel_mm`` (the target).

    ``hinge_stress_MPa`` maps hinge number (1-12) to the peak von Mises stress (MPa) in its
    neck and roots, fillets included (at a traction-free edge the stress is uniaxial along
    the edge, so this is also the magnitude of the largest principal stress there; at the
    sharp re-entrant corners of the drawn profile, kerf 0, it is singular and grows as the
    mesh is refined; with fillets it converges); ``hinge_peak_station_mm`` where that peak
    sits: its distance along the hinge axis from the nearer drawn root (positive: into the
    neck, where the fillet is; negative: in the body joined); ``hinge_neck_stress_MPa`` the
    peak on the neck's two faces at the stations at least one thickness t inside the
    uniform neck, past the root fillets (:func:`neck_points`; the middle station when the
    neck is shorter than 2 t), the beam theory's nominal stress there; ``hinge_corner_stress_MPa`` the peak in each quarter of the hinge's zone,
    ``[[start left, start right], [end left, end right]]``: the half nearer the drawn axis'
    start or its end, left or right of the axis (the axis runs as the beam model's member
    does, :func:`geometry.layout.make_parts`), so each root fillet's peak on its own.
    ``points`` (N, 2), ``triangles`` (M, 3), ``displacement_mm`` (N, 2) and
    ``von_mises_MPa`` (M, 3, at each triangle's corners) are the fields for pictures.
    ``size_mm`` is the element size in the thinnest hinge; ``kerf_mm`` the kerf of the
    profile solved (0: the drawing); ``punch_width_mm`` the width of the input's punch.
    """

    amplification: float
    k_out_N_per_mm: float
    strain_energy_mJ: float
    input_force_N: float
    input_travel_mm: float
    output_travel_mm: float
    hinge_stress_MPa: dict
    hinge_peak_station_mm: dict
    hinge_neck_stress_MPa: dict
    hinge_corner_stress_MPa: dict
    kerf_mm: float
    punch_width_mm: float
    plane_strain: bool
    nonlinear: bool
    mesh: str
    elements_across: float
    size_mm: float
    n_elements: int
    n_dofs: int
    points: np.ndarray
    triangles: np.ndarray
    displacement_mm: np.ndarray
    von_mises_MPa: np.ndarray
    #: nonlinear only (else None): how many eigenvalues of the tangent stiffness at the
    #: target, with the punch held, are negative (:func:`tangent_negative_modes`)
    negative_modes: int | None = None

    @property
    def stable(self) -> bool | None:
        """Whether the state at the target is stable (no negative mode); None when linear."""
        return None if self.negative_modes is None else self.negative_modes == 0


# --- geometry and mesh ---------------------------------------------------------------------

def cut_profile_loops(design: Design, kerf_mm: float | None = None):
    """Outline and holes (``x, y, bulge`` loops, mm) of the part a jet of width ``kerf_mm``
    (default the design's ``kerf_mm``) leaves: re-entrant corners rounded with radius
    kerf / 2 (kerf 0: the drawn profile), checked as ``dacm export`` checks it: no gap
    closes, every hinge neck keeps its width."""
    from geometry.cad import face_loops, offset_face, profile_face
    from geometry.export import kerf_path

    face = profile_face(design)
    kerf_mm = design.kerf_mm if kerf_mm is None else kerf_mm
    if not (math.isfinite(kerf_mm) and kerf_mm >= 0):
        raise SensorInputError(f"kerf_mm = {kerf_mm!r}: must be a non-negative number")
    if kerf_mm > 0:
        face = offset_face(kerf_path(design, face, kerf_mm), -kerf_mm / 2)
    return face_loops(face)


def _size_function(design: Design, n_across: float, kerf_mm: float = 0.0):
    """Target element size (mm) at a point: t / n_across in each hinge, growing away from it;
    around each hinge root (within t / 2 + 2 r of where its axis meets a face) at most
    r / n_across, r = kerf / 2, so that a fillet larger than the neck is resolved as finely
    as the neck and a smaller one by n_across elements over its radius: the peak stress in
    the fillet converges with the mesh (with t / n_across alone, fillets of r < t got two or
    three elements and the peak moved by up to 25 % between levels)."""
    hinges = [p for p in make_parts(make_layout(design)) if p.kind == "hinge"]
    a = np.array([p.axis[0] for p in hinges])
    b = np.array([p.axis[1] for p in hinges])
    ab = b - a
    ln2 = np.einsum("ij,ij->i", ab, ab)
    width = np.array([p.width for p in hinges])
    h_min = width / n_across
    reach = 1.5 * width
    h_max = 2.0 * min(design.link_width_mm, design.plate_thickness_mm) / n_across
    r = kerf_mm / 2
    roots = np.concatenate([a, b])
    h_root = np.tile(np.minimum(width, r) / n_across, 2) if r > 0 else np.full(len(roots), np.inf)
    root_reach = np.tile(width / 2 + 2 * r, 2)
    hinge_rows = np.ascontiguousarray(np.column_stack([a, ab, ln2, h_min, reach]))
    root_rows = np.ascontiguousarray(np.column_stack([roots, h_root, root_reach]))

    def size(x: float, y: float) -> float:
        return _element_size(x, y, hinge_rows, root_rows, h_max)

    size(0.0, 0.0)   # compiled (or failing) here: inside gmsh's callback an error is lost
    return size


@njit(cache=True, error_model="numpy")
def _element_size(x, y, hinges, roots, h_max):
    """The size of :func:`_size_function` at (x, y), mm: ``hinges`` rows (axis start x, y,
    axis vector x, y, its squared length, size in the hinge, reach), ``roots`` rows (x, y,
    size at the root, reach). Compiled: gmsh asks for it at every point it places (about half
    a million on a coarse study), and the same arithmetic in numpy took 70 us a call."""
    best = h_max
    for i in range(hinges.shape[0]):
        ax, ay, abx, aby, ln2, h_min, reach = hinges[i]
        s = min(max(((x - ax) * abx + (y - ay) * aby) / ln2, 0.0), 1.0)   # nearest station on the axis
        dx, dy = ax + s * abx - x, ay + s * aby - y
        best = min(best, h_min + 0.5 * max(math.sqrt(dx * dx + dy * dy) - reach, 0.0))
    for j in range(roots.shape[0]):
        rx, ry, h_root, reach = roots[j]
        dx, dy = rx - x, ry - y
        best = min(best, h_root + 0.5 * max(math.sqrt(dx * dx + dy * dy) - reach, 0.0))
    return best


def _arc_centre(s, e, bulge):
    theta = 4.0 * math.atan(bulge)
    c = np.linalg.norm(e - s)
    r = c / (2.0 * math.sin(abs(theta) / 2.0))
    normal = np.array([-(e - s)[1], (e - s)[0]]) / c
    return (s + e) / 2 + normal * math.copysign(r * math.cos(theta / 2.0), bulge)


def _split_at(loop: np.ndarray, xs: tuple[float, ...], y: float) -> np.ndarray:
    """Insert vertices at (x, y) for each x lying on a straight horizontal edge of the loop."""
    out = []
    n = len(loop)
    for i in range(n):
        s, e, bulge = loop[i, :2], loop[(i + 1) % n, :2], loop[i, 2]
        out.append(loop[i])
        if bulge == 0.0 and abs(s[1] - y) < 1e-9 and abs(e[1] - y) < 1e-9:
            inner = [x for x in xs if min(s[0], e[0]) + 1e-9 < x < max(s[0], e[0]) - 1e-9]
            for x in sorted(inner, reverse=bool(e[0] < s[0])):
                out.append(np.array([x, y, 0.0]))
    return np.array(out)


def mesh_profile(design: Design, n_across: float, punch_width_mm: float = INPUT_CONTACT_MM,
                 kerf_mm: float | None = None):
    """Linear triangles (points (N, 2), triangles (M, 3)) of the profile cut with ``kerf_mm``
    (see :func:`cut_profile_loops`), ``n_across`` elements across each hinge; vertices at
    the punch's edges on the top face."""
    outline, holes = cut_profile_loops(design, kerf_mm)
    outline = _split_at(outline, (-punch_width_mm / 2, punch_width_mm / 2), design.height_mm)
    size = _size_function(design, n_across, design.kerf_mm if kerf_mm is None else kerf_mm)
    with gmsh_session("profile") as gmsh:
        geo = gmsh.model.geo
        loops = []
        for loop in [outline] + list(holes):
            pts = [geo.addPoint(float(x), float(y), 0.0) for x, y, _ in loop]
            curves = []
            for i, (x, y, bulge) in enumerate(loop):
                j = (i + 1) % len(loop)
                if bulge == 0.0:
                    curves.append(geo.addLine(pts[i], pts[j]))
                else:
                    c = _arc_centre(loop[i, :2], loop[j, :2], bulge)
                    ct = geo.addPoint(float(c[0]), float(c[1]), 0.0)
                    if abs(4 * math.atan(bulge)) > math.pi - 1e-6:  # split a half circle or more
                        mid = c + np.linalg.norm(loop[i, :2] - c) * _unit_mid(loop[i, :2], loop[j, :2], c, bulge)
                        pm = geo.addPoint(float(mid[0]), float(mid[1]), 0.0)
                        curves += [geo.addCircleArc(pts[i], ct, pm), geo.addCircleArc(pm, ct, pts[j])]
                    else:
                        curves.append(geo.addCircleArc(pts[i], ct, pts[j]))
            loops.append(geo.addCurveLoop(curves))
        geo.addPlaneSurface(loops)
        geo.synchronize()
        try:
            return mesh_surface(size)
        except Exception as exc:  # noqa: BLE001 (gmsh reports every failure as a plain Exception)
            raise SolverError(f"gmsh could not mesh the profile of {design.name!r} at "
                              f"{n_across:g} elements across a hinge: {exc}") from None


@contextlib.contextmanager
def gmsh_session(name: str):
    """An initialised gmsh (no configuration files, no terminal output) with an empty model
    ``name``, finalised on leaving."""
    import gmsh

    gmsh.initialize(["-noenv"], readConfigFiles=False)
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        gmsh.model.add(name)
        yield gmsh
    finally:
        gmsh.finalize()


def mesh_surface(size) -> tuple[np.ndarray, np.ndarray]:
    """Linear triangles of the plane surface of the open gmsh model, element size
    ``size(x, y)`` (mm) everywhere (from nothing else: not the points, the boundary or the
    curvature): points (N, 2) and triangles (M, 3) indexing them, nodes no triangle uses
    dropped."""
    import gmsh

    for option in ("Mesh.MeshSizeExtendFromBoundary", "Mesh.MeshSizeFromPoints", "Mesh.MeshSizeFromCurvature"):
        gmsh.option.setNumber(option, 0)
    gmsh.option.setNumber("Mesh.Algorithm", 6)
    gmsh.model.mesh.setSizeCallback(lambda dim, tag, x, y, z, lc: size(x, y))
    gmsh.model.mesh.generate(2)
    return mesh_elements(2)


#: gmsh's element type of the linear simplex of each dimension: 3-node triangle, 4-node tetrahedron
_GMSH_SIMPLEX = {2: 2, 3: 4}


def mesh_elements(dim: int) -> tuple[np.ndarray, np.ndarray]:
    """The open gmsh model's linear simplices of dimension ``dim`` (triangles or tetrahedra,
    as gmsh orients them): points (N, dim) and cells (M, dim + 1) indexing them, nodes no
    cell uses dropped."""
    import gmsh

    tags, xyz, _ = gmsh.model.mesh.getNodes()
    etypes, _, enodes = gmsh.model.mesh.getElements(dim)
    if _GMSH_SIMPLEX[dim] not in list(etypes):
        raise SolverError(f"gmsh made no {('triangles', 'tetrahedra')[dim - 2]} of the model: its outline is "
                          "degenerate (a zero-width spike or a self-touching edge)")
    cells = np.asarray(enodes[list(etypes).index(_GMSH_SIMPLEX[dim])], dtype=np.int64).reshape(-1, dim + 1)
    index = np.zeros(int(tags.max()) + 1, dtype=np.int64)
    index[tags.astype(np.int64)] = np.arange(len(tags))
    points = xyz.reshape(-1, 3)[:, :dim]
    cells = index[cells]
    used = np.unique(cells)
    remap = np.zeros(len(points), dtype=np.int64)
    remap[used] = np.arange(len(used))
    return points[used], remap[cells]


def _unit_mid(s, e, c, bulge):
    """Unit vector from the centre c to the middle of the arc s -> e of the given bulge."""
    a0 = math.atan2(*(s - c)[::-1])
    a = a0 + 2.0 * math.atan(bulge)
    return np.array([math.cos(a), math.sin(a)])


# --- the FE model ------------------------------------------------------------------------

def _lame(E: float, nu: float, plane_strain: bool) -> tuple[float, float]:
    """2D Lame constants (MPa): plane strain as is, plane stress with lambda* = 2 lam mu / (lam + 2 mu)."""
    lam = E * nu / ((1 + nu) * (1 - 2 * nu))
    mu = E / (2 * (1 + nu))
    if not plane_strain:
        lam = 2 * lam * mu / (lam + 2 * mu)
    return lam, mu


def _von_mises(eps: np.ndarray, lam: float, mu: float, nu: float, plane_strain: bool) -> np.ndarray:
    """Von Mises stress (MPa) from in-plane strains eps (2, 2, ...)."""
    tr = eps[0, 0] + eps[1, 1]
    sxx = lam * tr + 2 * mu * eps[0, 0]
    syy = lam * tr + 2 * mu * eps[1, 1]
    sxy = 2 * mu * eps[0, 1]
    szz = nu * (sxx + syy) if plane_strain else 0.0
    return np.sqrt(0.5 * ((sxx - syy) ** 2 + (syy - szz) ** 2 + (szz - sxx) ** 2) + 3 * sxy**2)


@dataclass(frozen=True, eq=False)
class BodyProblem:
    """The discrete problem of one mesh: basis, linear stiffness and the port dofs."""

    basis: object
    K: object                # linear stiffness (N/mm), sheet thickness included
    fixed: np.ndarray        # clamped dofs
    punch_y: np.ndarray      # punch dofs pushed down
    punch_x: np.ndarray      # punch dofs held sideways
    out_row: object          # (N,) sparse row: mirror travel minus fiber-tip travel, up positive
    lam: float
    mu: float
    depth: float


def body_problem(design: Design, points, triangles, plane_strain, punch_width_mm, clamp) -> BodyProblem:
    """The discrete problem of a body's mesh (points (n, 2) mm, quadratic triangles (m, 3)
    of :func:`mesh_profile`): its linear stiffness, the clamp (one of :data:`CLAMPS`), the
    punch ``punch_width_mm`` wide on the top face and the mirror-minus-fiber-tip output row.
    :func:`verify` solves it; studies may change its stiffness first (the part study's rigid
    cores)."""
    from skfem import Basis, ElementTriP2, ElementVector, MeshTri, asm
    from skfem.models.elasticity import linear_elasticity

    mesh = MeshTri(np.ascontiguousarray(points.T), np.ascontiguousarray(triangles.T))
    basis = Basis(mesh, ElementVector(ElementTriP2()), intorder=4)
    lam, mu = _lame(design.material.E_MPa, design.material.nu, plane_strain)
    K = asm(linear_elasticity(lam, mu), basis) * design.sheet_thickness_mm
    lay = make_layout(design)
    tol = 1e-7
    if clamp == "bottom edge":
        fixed = basis.get_dofs(mesh.facets_satisfying(lambda x: x[1] < tol, boundaries_only=True)).all()
    else:
        fixed = basis.get_dofs(elements=mesh.elements_satisfying(lambda x: x[1] < lay.y_base)).all()
    punch = mesh.facets_satisfying(
        lambda x: (x[1] > design.height_mm - tol) & (np.abs(x[0]) < punch_width_mm / 2 + tol),
        boundaries_only=True)
    pd = basis.get_dofs(punch)
    # probes just inside the body: rows 0-1 are u_x, rows 2-3 u_y of (mirror, fiber tip)
    P = basis.probes(np.array([[0.0, 0.0], [lay.output_point[1] + 1e-6, lay.post_top - 1e-6]])).tocsr()
    return BodyProblem(basis, K, fixed, pd.all("u^2"), pd.all("u^1"), (P[2] - P[3]).toarray().ravel(),
                    lam, mu, design.sheet_thickness_mm)


def _prescribed(pb: BodyProblem, travel_mm: float):
    """Dof indices and values of the Dirichlet conditions at an input travel (down)."""
    idx = np.concatenate([pb.fixed, pb.punch_x, pb.punch_y])
    val = np.concatenate([np.zeros(len(pb.fixed) + len(pb.punch_x)), np.full(len(pb.punch_y), -travel_mm)])
    return idx, val


def unit_travel_state(pb: BodyProblem) -> tuple[np.ndarray, float, float]:
    """The linear state at 1 mm of input travel (the punch pushed down): displacements, the
    mirror's output travel down (mm; ``out_row`` reads it up-positive) and the punch's force
    (N)."""
    idx, val = _prescribed(pb, 1.0)
    u = _solve_dirichlet(pb.K, np.zeros(pb.K.shape[0]), idx, val)
    return u, -float(pb.out_row @ u), -float((pb.K @ u)[pb.punch_y].sum())


def _solve_dirichlet(K, rhs, idx, val, u0=None):
    """Solve K u = rhs with u[idx] = val (later entries win); returns u."""
    n = K.shape[0]
    u = np.zeros(n) if u0 is None else u0.copy()
    u[idx] = val
    free = np.ones(n, bool)
    free[idx] = False
    Kff = K[free][:, free].tocsc()
    u[free] = spla.spsolve(Kff, (rhs - K @ u)[free])
    return u


def _corner_gradients(pb: BodyProblem, u: np.ndarray) -> np.ndarray:
    """Displacement gradients (2, 2, M, 3) at each triangle's three corners."""
    from skfem import Basis

    corners = (np.array([[0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]), np.full(3, 1.0 / 6.0))
    vb = Basis(pb.basis.mesh, pb.basis.elem, quadrature=corners)
    return np.asarray(vb.interpolate(u).grad)


def _gradients_at(pb: BodyProblem, G: np.ndarray, xy: np.ndarray) -> np.ndarray:
    """Displacement gradients (2, 2, P, 1) at points ``xy`` (P, 2) inside the mesh, from the
    corner gradients ``G`` (2, 2, M, 3): a quadratic element's gradient is linear, so the
    barycentric interpolation of its corner values is exact."""
    mesh = pb.basis.mesh
    elems = mesh.element_finder()(xy[:, 0], xy[:, 1])
    v = mesh.p[:, mesh.t[:, elems]]                      # (2, 3, P)
    d1, d2, r = v[:, 1] - v[:, 0], v[:, 2] - v[:, 0], xy.T - v[:, 0]
    det = d1[0] * d2[1] - d1[1] * d2[0]
    l1 = (r[0] * d2[1] - r[1] * d2[0]) / det
    l2 = (d1[0] * r[1] - d1[1] * r[0]) / det
    weights = np.stack([1.0 - l1 - l2, l1, l2])          # (3, P)
    return np.einsum("ijpk,kp->ijp", G[:, :, elems, :], weights)[..., None]


def _von_mises_of(pb: BodyProblem, G: np.ndarray, nu: float, plane_strain: bool, nonlinear: bool):
    """Von Mises stress (MPa, shape G.shape[2:]) from displacement gradients G (2, 2, a, b):
    Cauchy stress of the SVK law (the linear law when not ``nonlinear``)."""
    if not nonlinear:
        eps = 0.5 * (G + G.transpose(1, 0, 2, 3))
        return _von_mises(eps, pb.lam, pb.mu, nu, plane_strain)
    F = G + np.eye(2)[:, :, None, None]
    E = 0.5 * (np.einsum("kiab,kjab->ijab", F, F) - np.eye(2)[:, :, None, None])
    S = pb.lam * (E[0, 0] + E[1, 1]) * np.eye(2)[:, :, None, None] + 2 * pb.mu * E
    J = F[0, 0] * F[1, 1] - F[0, 1] * F[1, 0]
    sig = np.einsum("ikab,klab,jlab->ijab", F, S, F) / J
    # the same von Mises formula, written for a stress: pass it as a "strain" with lam = 0, 2 mu = 1
    return _von_mises(sig, 0.0, 0.5, nu, plane_strain)


#: Stations per face at which the neck stress is sampled (:func:`neck_points`).
NECK_STATIONS = 41


def _hinge_frames(design: Design):
    """Per hinge: (number, root point a (2,), unit axis u, unit normal n, drawn length L, t)."""
    for p in make_parts(make_layout(design)):
        if p.kind == "hinge":
            a, b = p.axis
            L = float(np.linalg.norm(b - a))
            u = (b - a) / L
            yield p.hinge, a, u, np.array([-u[1], u[0]]), L, p.width


def hinge_zones(design: Design, xy: np.ndarray, kerf_mm: float = 0.0) -> dict[int, tuple]:
    """Per hinge, a boolean mask over points ``xy`` (..., 2) of the whole hinge (neck and
    both roots: the fillets of radius kerf / 2 and t + kerf / 2 into the bodies it joins),
    each point's station along the drawn axis from its start (mm), its offset across the
    axis (mm, positive on the left) and the drawn length L (mm)."""
    out = {}
    pad = kerf_mm / 2
    for h, a, u, nrm, L, t in _hinge_frames(design):
        rel = xy - a
        s, y = rel @ u, rel @ nrm
        reach = t + pad
        whole = (s > -reach) & (s < L + reach) & (np.abs(y) < t / 2 + pad + 1e-6)
        out[h] = (whole, s, y, L)
    return out


def neck_points(design: Design) -> dict[int, np.ndarray]:
    """Per hinge, points (2 NECK_STATIONS, 2) on the neck's two faces (just inside) at the
    stations at least one thickness inside the uniform neck, where the beam's nominal
    stress holds: from t past where the neck starts to t before it ends, as
    :func:`sensor.mechanics.stress.hinge_stresses` takes them (the beam model's
    ``neck_mm``, past the root fillets of the part as cut, the design's ``kerf_mm``; the
    middle station when the neck is shorter than 2 t)."""

    model = build_beam_model(design)
    span = {int(model.hinge_number[i]): (model.nodes[model.member_nodes[i, 0]], model.neck_mm[i])
            for i in model.hinge_members}
    out = {}
    for h, a, u, nrm, L, t in _hinge_frames(design):
        start, (n0, n1) = span[h]
        behind = float((start - a) @ u)               # the member starts this far along the axis
        lo, hi = n0 + behind + t, n1 + behind - t
        s = np.linspace(lo, hi, NECK_STATIONS) if hi >= lo else np.full(NECK_STATIONS, (lo + hi) / 2)
        face = 0.5 * t * (1.0 - 1e-6)
        out[h] = np.concatenate([a + s[:, None] * u + side * face * nrm for side in (1.0, -1.0)])
    return out


_I2 = np.eye(2)[:, :, None, None]


def _green_lagrange(grad_u):
    """Deformation gradient F = I + grad u and Green-Lagrange strain E = (F^T F - I) / 2 at
    the quadrature points (skfem's (2, 2, elements, points) layout)."""
    F = _I2 + grad_u
    return F, 0.5 * (np.einsum("kiab,kjab->ijab", F, F) - _I2)


def _svk_forms(lam: float, mu: float):
    """The total-Lagrangian St Venant-Kirchhoff forms: (tangent stiffness, internal force),
    per unit sheet thickness, at the displacement ``u`` passed to :func:`skfem.asm`."""
    from skfem import BilinearForm, LinearForm

    I = _I2  # noqa: E741 (the identity, as in the formulas)

    def kinematics(w):
        F, E = _green_lagrange(w["u"].grad)
        S = lam * (E[0, 0] + E[1, 1]) * I + 2 * mu * E
        return F, S

    @BilinearForm
    def tangent(du, v, w):
        F, S = kinematics(w)
        gdu = du.grad
        dE = 0.5 * (np.einsum("kiab,kjab->ijab", F, gdu) + np.einsum("kiab,kjab->ijab", gdu, F))
        dS = lam * (dE[0, 0] + dE[1, 1]) * I + 2 * mu * dE
        T = np.einsum("ikab,kjab->ijab", gdu, S) + np.einsum("ikab,kjab->ijab", F, dS)
        return np.einsum("ijab,ijab->ab", T, v.grad)

    @LinearForm
    def internal(v, w):
        F, S = kinematics(w)
        return np.einsum("ijab,ijab->ab", np.einsum("ikab,kjab->ijab", F, S), v.grad)

    return tangent, internal


def tangent_negative_modes(pb: BodyProblem, u: np.ndarray) -> int:
    """How many eigenvalues of the tangent stiffness at the state u, with the clamp and the
    punch held (the guided punch of the test, driven by its travel), are negative: 0 when
    the state is stable (an equilibrium is stable when the second variation of the
    potential energy, the tangent stiffness, is positive definite: Bazant & Cedolin,
    Stability of Structures, 1991). Newton follows the symmetric path through a sideways
    bifurcation without noticing; past the first, this counts the modes crossed.

    The count is the matrix's inertia (:func:`negative_eigenvalues`; checked against the
    clamped column's buckling loads in tests/mechanics/test_continuum.py). Only the sign is
    meaningful: the eigenvalues of a stiffness without a mass matrix scale with the mesh.
    """
    from skfem import asm

    tangent, _ = _svk_forms(pb.lam, pb.mu)
    K = asm(tangent, pb.basis, u=pb.basis.interpolate(u)) * pb.depth
    free = np.ones(K.shape[0], bool)
    free[_prescribed(pb, 0.0)[0]] = False
    Kf = K[free][:, free]
    return negative_eigenvalues(0.5 * (Kf + Kf.T))   # symmetric up to round-off (hyperelastic)


def negative_eigenvalues(H) -> int:
    """Number of negative eigenvalues of a symmetric sparse matrix, by Sylvester's law of
    inertia: SuperLU in symmetric mode without row pivoting gives P H P^T = L D L^T, and the
    signs of D (the diagonal of U = D L^T) are those of the eigenvalues."""
    lu = spla.splu(H.tocsc(), permc_spec="MMD_AT_PLUS_A", diag_pivot_thresh=0.0,
                   options={"SymmetricMode": True})
    if not np.array_equal(lu.perm_r, lu.perm_c):
        raise SolverError("the LU factorisation pivoted off the diagonal: inertia unknown")
    return int((lu.U.diagonal() < 0).sum())


def _newton_tl(pb: BodyProblem, u: np.ndarray, travel_mm: float, tol: float = 1e-9, max_iter: int = 25):
    """Total-Lagrangian equilibrium (St Venant-Kirchhoff) at an input travel, from u."""
    from skfem import asm

    tangent, internal = _svk_forms(pb.lam, pb.mu)
    idx, val = _prescribed(pb, travel_mm)
    u = u.copy()
    u[idx] = val
    free = np.ones(len(u), bool)
    free[idx] = False
    scale = None
    prev = np.inf
    for _ in range(max_iter):
        w = pb.basis.interpolate(u)
        r = asm(internal, pb.basis, u=w) * pb.depth
        if scale is None:
            scale = max(np.linalg.norm(r[~free]), 1e-30)
        res = np.linalg.norm(r[free]) / scale
        # converged, or stalled at round-off (below sqrt(tol) and no longer halving)
        if res < tol or (res < math.sqrt(tol) and res > 0.5 * prev):
            return u, r
        prev = res
        K = asm(tangent, pb.basis, u=w) * pb.depth
        u[free] -= spla.spsolve(K[free][:, free].tocsc(), r[free])
    raise ConvergenceError(f"continuum Newton iterations at input travel {travel_mm:.4g} mm: "
                           f"residual {res:.2e} did not fall below {tol:g}")


def verify(design: Design, mesh: str = "default", plane_strain: bool = False,
           nonlinear: bool = False, target_output_mm: float = 1.0, punch_width_mm: float | None = None,
           clamp: str = "bottom edge", kerf_mm: float | None = None,
           increments: int = 4) -> ContinuumResult:
    """Solve the continuum model of a design at one mesh level (see the module docstring).

    ``mesh`` is a level of :data:`MESH_LEVELS` or a number of elements across each hinge;
    ``kerf_mm`` (default the design's ``kerf_mm``: the part as cut) rounds the re-entrant
    corners as a jet of that width does (0: the drawn profile of the DXF, sharp corners);
    a larger drawn ``root_radius_mm`` of the design rounds them with that radius instead
    (every re-entrant corner, as :func:`geometry.topology.root_radius_mm` gives the roots).
    Results are reported at the output travel ``target_output_mm`` (linear: scaled to it);
    nonlinear results also say whether that state is stable. The punch is ``punch_width_mm``
    wide (default :func:`geometry.topology.input_contact_mm`:
    :data:`~geometry.topology.INPUT_CONTACT_MM`, less on a top plate under 1 mm).
    """
    n_across = MESH_LEVELS.get(mesh) if isinstance(mesh, str) else float(mesh)
    if n_across is None or not (math.isfinite(n_across) and n_across > 0):
        raise SensorInputError(f"mesh = {mesh!r}: must be one of {', '.join(MESH_LEVELS)} or a "
                               "positive number of elements across a hinge")
    if clamp not in CLAMPS:
        raise SensorInputError(f"clamp = {clamp!r}: must be one of {', '.join(CLAMPS)}")
    if not (math.isfinite(target_output_mm) and target_output_mm > 0):
        raise SensorInputError(f"target_output_mm = {target_output_mm!r}: must be a positive finite number (mm)")

    punch_width_mm = input_contact_mm(design) if punch_width_mm is None else punch_width_mm
    contact_rule(design).check("punch_width_mm", punch_width_mm, SensorInputError)

    if kerf_mm is not None:
        FIELD_RULES["kerf_mm"].check("kerf_mm", kerf_mm, SensorInputError)
    kerf = design.kerf_mm if kerf_mm is None else kerf_mm
    # the roots' fillet: the jet's, or the drawn root radius where larger (as the beam model
    # takes it); a jet twice that wide leaves it at every re-entrant corner
    rounding = 2.0 * root_radius_mm(design.replace(kerf_mm=kerf))
    points, triangles = mesh_profile(design, n_across, punch_width_mm, rounding)
    pb = body_problem(design, points, triangles, plane_strain, punch_width_mm, clamp)
    triangles = pb.basis.mesh.t.T      # skfem sorts each triangle's corners: use its order
    u, out_lin, _ = unit_travel_state(pb)
    if not out_lin > 0:
        raise SensorInputError(f"design {design.name!r}: the mirror moves up ({out_lin:.3g} mm per mm "
                               "of input): no output travel to report")
    travel = target_output_mm / out_lin
    negative = None
    if not nonlinear:
        u = u * travel
        force = -float((pb.K @ u)[pb.punch_y].sum())
        energy = 0.5 * float(u @ (pb.K @ u))
    else:
        u, travel, force = nonlinear_to_target(pb, u * travel, travel, target_output_mm, increments)
        energy = _svk_energy(pb, u)
        negative = tangent_negative_modes(pb, u)
    out = -float(pb.out_row @ u)
    G = _corner_gradients(pb, u)
    vm = _von_mises_of(pb, G, design.material.nu, plane_strain, nonlinear)
    stress, station, corner = {}, {}, {}
    for h, (zone, s, y, L) in sorted(hinge_zones(design, points[triangles], rounding).items()):
        k = np.argmax(np.where(zone, vm, -np.inf))
        stress[h], station[h] = float(vm.flat[k]), float(min(s.flat[k], L - s.flat[k]))
        corner[h] = [[float(np.max(vm, where=zone & end & side, initial=0.0)) for side in (y > 0, y <= 0)]
                     for end in (s < L / 2, s >= L / 2)]
    neck = {h: float(_von_mises_of(pb, _gradients_at(pb, G, xy), design.material.nu, plane_strain,
                                   nonlinear).max())
            for h, xy in sorted(neck_points(design.replace(kerf_mm=kerf)).items())}
    return ContinuumResult(
        amplification=out / travel, k_out_N_per_mm=force / out, strain_energy_mJ=energy,
        input_force_N=force, input_travel_mm=travel, output_travel_mm=out,
        hinge_stress_MPa=stress, hinge_peak_station_mm=station, hinge_neck_stress_MPa=neck,
        hinge_corner_stress_MPa=corner,
        kerf_mm=float(kerf), punch_width_mm=float(punch_width_mm), plane_strain=plane_strain, nonlinear=nonlinear,
        mesh=str(mesh), elements_across=n_across, size_mm=min(design.used_thickness_mm) / n_across,
        n_elements=len(triangles), n_dofs=pb.K.shape[0], points=points, triangles=triangles,
        displacement_mm=u[pb.basis.nodal_dofs].T[: len(points)].copy(), von_mises_MPa=vm,
        negative_modes=negative)


def nonlinear_to_target(pb: BodyProblem, u_lin, travel_lin, target, increments):
    """The geometrically nonlinear state (St Venant-Kirchhoff, total Lagrangian) at the output
    travel ``target`` (mm), from the linear state ``u_lin`` at the input travel ``travel_lin``
    (mm) estimated to give it: Newton in ``increments`` increments of input travel, then
    secant steps on the travel until the output travel equals ``target`` (relative 1e-9).
    Returns (u, input travel mm, input force N)."""
    u = np.zeros_like(u_lin)
    travel = travel_lin
    for k in range(1, increments + 1):
        u, r = _newton_tl(pb, u + u_lin / increments, travel * k / increments)
    history = [(travel, -float(pb.out_row @ u))]
    for _ in range(20):
        t0, o0 = history[-1]
        if abs(o0 - target) < 1e-9 * target:
            break
        if len(history) == 1:
            t1 = t0 * target / o0
        else:
            (ta, oa), (tb, ob) = history[-2:]
            t1 = tb + (target - ob) * (tb - ta) / (ob - oa)
        u, r = _newton_tl(pb, u * (t1 / t0), t1)
        history.append((t1, -float(pb.out_row @ u)))
    else:
        raise ConvergenceError(f"continuum: output travel {history[-1][1]:.6g} mm did not reach the "
                               f"target {target:g} mm")
    force = -float(r[pb.punch_y].sum())
    return u, history[-1][0], force


def _svk_energy(pb: BodyProblem, u: np.ndarray) -> float:
    """Strain energy (mJ) of the St Venant-Kirchhoff law: integral of lam/2 tr(E)^2 + mu E:E."""
    from skfem import Functional, asm

    @Functional
    def density(w):
        _, E = _green_lagrange(w["u"].grad)
        return 0.5 * pb.lam * (E[0, 0] + E[1, 1]) ** 2 + pb.mu * np.einsum("ijab,ijab->ab", E, E)

    return float(asm(density, pb.basis, u=pb.basis.interpolate(u))) * pb.depth


@dataclass(frozen=True)
class Convergence:
    """Richardson extrapolation of a quantity from three meshes refined by a constant ratio.

    ``values`` coarse to fine; ``order`` the observed order of convergence in element size;
    ``extrapolated`` the mesh-converged estimate; ``error_pct`` the finest mesh's estimated
    error relative to it (percent).
    """

    values: tuple[float, float, float]
    order: float
    extrapolated: float
    error_pct: float


#: Size ratio between the three meshes of a convergence study.
REFINEMENT_RATIO = math.sqrt(2.0)


def richardson(values, ratio: float = REFINEMENT_RATIO) -> Convergence:
    """Observed order and extrapolated value from three values on meshes h r^2, h r, h.

    Outside the asymptotic range (differences not shrinking monotonically, or an observed
    order outside ORDER_RANGE) the order is NaN, the estimate is the finest value and its
    error the last difference times 1 / (ratio - 1) (what first order would leave).
    """
    f1, f2, f3 = (float(v) for v in values)
    d1, d2 = f2 - f1, f3 - f2
    p = float("nan")
    if d1 != 0 and d2 != 0 and d2 / d1 > 0 and abs(d2) < abs(d1):
        p = math.log(d1 / d2) / math.log(ratio)
    if ORDER_RANGE[0] <= p <= ORDER_RANGE[1]:
        ext = f3 + d2 / (ratio**p - 1)
        return Convergence((f1, f2, f3), p, ext, abs(relative_error_pct(f3, ext)))
    return Convergence((f1, f2, f3), float("nan"), f3, abs(relative_error_pct(f3 + d2 / (ratio - 1), f3)))


def relative_error_pct(value: float, reference: float) -> float:
    """100 (value / reference - 1); NaN for a zero reference (a quantity that passes through
    zero, such as a knee's rotation, has no relative error there)."""
    return 100 * (value / reference - 1) if reference else float("nan")


#: Observed orders accepted for extrapolation: quadratic elements converge in energy at
#: order 2 k_s with k_s the corner singularity's exponent (0.54 at a re-entrant right-angle
#: corner, so about 1.1), up to 4 on smooth solutions.
ORDER_RANGE = (0.5, 4.0)


CONVERGED = ("amplification", "k_out_N_per_mm", "strain_energy_mJ")


def convergence_study(design: Design, mesh: str | float = "default", **options):
    """Solve at three meshes (``mesh`` and two coarser by sqrt(2) and 2 in element size).

    Returns (results coarse to fine, {quantity: :class:`Convergence`}) for the quantities of
    :data:`CONVERGED`.
    """
    n = MESH_LEVELS.get(mesh) if isinstance(mesh, str) else float(mesh)
    if n is None:
        raise SensorInputError(f"mesh = {mesh!r}: must be one of {', '.join(MESH_LEVELS)} or a "
                               "positive number of elements across a hinge")
    runs = [verify(design, mesh=n / REFINEMENT_RATIO**k, **options) for k in (2, 1, 0)]
    return runs, {q: richardson([getattr(r, q) for r in runs]) for q in CONVERGED}


# --- the beam model beside the continuum -------------------------------------------------

#: The knee's motion compared (:func:`knee_motion_fe`): where an error in A comes from, the
#: side chains that move the knee or the middle branch that turns its motion into output.
KNEE_MOTION = ("knee_outward_per_input", "knee_rotation_per_input_rad_per_mm")
#: How far inside the knee block's edges (mm) the FE's knee motion is read: the hinge roots
#: deform the block's rim, its core moves nearly as a rigid body (the beam model's knee
#: bends only as two stubs as wide as the block).
KNEE_MARGIN_MM = 0.5


def _knee(design: Design) -> tuple[np.ndarray, np.ndarray]:
    """The left knee block: its centre and its (lower-left, upper-right) corners, mm."""
    lay = make_layout(design)
    poly = np.vstack([p.polygon for p in make_parts(lay) if p.body == "left knee"])
    lo, hi = poly.min(axis=0), poly.max(axis=0)
    return (lo + hi) / 2, np.array([lo, hi])


def knee_motion_fe(design: Design, fe: ContinuumResult) -> dict:
    """The left knee's motion per mm of input travel in the FE: ``knee_outward_per_input``
    (its centre's travel away from the middle, mm/mm) and ``knee_rotation_per_input_rad_per_mm``
    (counter-clockwise), the rigid motion fitted by least squares to the nodes at least
    :data:`KNEE_MARGIN_MM` inside the block, and ``knee_fit_residual`` (RMS misfit of that
    rigid motion over its size: how rigid the core is)."""
    centre, (lo, hi) = _knee(design)
    margin = min(KNEE_MARGIN_MM, 0.25 * float(np.min(hi - lo)))   # a small knee keeps half its size
    inside = np.all((fe.points > lo + margin) & (fe.points < hi - margin), axis=1)
    if inside.sum() < 3:
        raise SolverError(f"continuum: {int(inside.sum())} mesh nodes inside the knee block's core: "
                          "too few to read its motion")
    r = fe.points[inside] - centre
    A = np.zeros((2 * len(r), 3))
    A[0::2, 0] = A[1::2, 1] = 1.0
    A[0::2, 2], A[1::2, 2] = -r[:, 1], r[:, 0]
    b = fe.displacement_mm[inside].ravel()
    x = np.linalg.lstsq(A, b, rcond=None)[0]
    ux, uy, turn = x
    misfit = np.sqrt(np.mean((A @ x - b) ** 2)) / max(math.hypot(ux, uy), 1e-30)
    return {"knee_outward_per_input": float(-ux / fe.input_travel_mm),
            "knee_rotation_per_input_rad_per_mm": float(turn / fe.input_travel_mm),
            "knee_fit_residual": float(misfit)}


def knee_motion_beam(design: Design, model, result) -> dict:
    """The left knee's motion per mm of input travel in the beam model (its centre node, where
    the block's two stubs meet): the keys of :func:`knee_motion_fe` but the residual."""
    centre, _ = _knee(design)
    node = int(np.argmin(np.linalg.norm(model.nodes - centre, axis=1)))
    if np.linalg.norm(model.nodes[node] - centre) > 1e-9:
        raise SolverError(f"beam model of {design.name!r} has no node at the left knee's centre")
    ux = result.deformed_nodes[node, 0] - model.nodes[node, 0]
    turn = result.node_rotation_rad[node]
    return {"knee_outward_per_input": float(-ux / result.input_travel_mm),
            "knee_rotation_per_input_rad_per_mm": float(turn / result.input_travel_mm)}


@dataclass(frozen=True, eq=False)
class Verification:
    """The continuum FE of a design beside its beam model (:func:`verify_design`).

    ``design`` carries the kerf solved (``design.kerf_mm``; 0: the drawing). ``fe`` is the
    finest of the three meshes (nonlinear on one mesh: the coarsest, solved nonlinear, the
    three in ``runs`` linear, see :func:`verify_design`); ``convergence`` holds the
    Richardson study of A, k_out, SE and the knee's motion (:data:`KNEE_MOTION`), and ``convergence["hinge_peak_stress_MPa"]``
    one per hinge of the FE peak;
    ``beam`` and ``fe_summary`` are dicts with ``amplification``, ``k_out_N_per_mm``,
    ``strain_energy_mJ`` (FE: the extrapolated values) and ``hinge_stress_MPa`` (the nominal
    stress one thickness inside each neck, where both models are mesh- and root-independent)
    and ``hinge_peak_stress_MPa`` (beam: its Kt x the nominal root stress; FE: the peak von
    Mises stress in the neck and its root fillets on the finest mesh, converged with fillets,
    singular at the sharp corners of kerf 0), FE also ``hinge_peak_station_mm`` (where the
    peak sits, see :class:`ContinuumResult`); both also ``peak_stress_MPa``,
    ``peak_stress_hinge`` and ``stress_utilisation`` (the largest peak against the
    material's allowable stress; FE: None on sharp roots, where the peak is singular), and
    the left knee's motion per mm of input (:data:`KNEE_MOTION`; FE: extrapolated from the
    three meshes like A, its study in ``convergence``, and the finest mesh's
    ``knee_fit_residual``); ``errors_pct`` the beam's errors relative to the FE.
    When the beam model's path stops being stable before the target (nonlinear), ``beam``
    is ``{"unstable": why}`` and ``errors_pct`` is empty: compare ``fe.stable``.
    """

    design: Design
    mesh: str
    fe: ContinuumResult
    runs: tuple
    convergence: dict
    fe_summary: dict
    beam: dict
    errors_pct: dict


def _beam_side(design: Design, target_output_mm: float, nonlinear: bool, punch_width_mm: float) -> dict:
    """The beam model's values beside the FE's, its input spread over the punch's width
    (mm), or, nonlinear, ``{"unstable": why}`` when its path stops being stable before the
    target (its Newton iterations may also fail just past the bifurcation: a
    ConvergenceError)."""
    from sensor.errors import InstabilityError
    from sensor.mechanics.solver import solve
    from sensor.mechanics.stress import hinge_stresses

    model = build_beam_model(design, contact_mm=punch_width_mm)
    travel = target_output_mm if nonlinear else target_output_mm * LINEAR_LIMIT_FRACTION
    try:
        r = solve(model, target_output_mm=travel)
    except (InstabilityError, ConvergenceError) as exc:
        if not nonlinear:
            raise
        return {"unstable": str(exc)}
    scale = target_output_mm / r.output_travel_mm
    s = hinge_stresses(model, r)
    peak = {h: v.peak_MPa * scale for h, v in s.items()}
    return {"amplification": r.amplification, "k_out_N_per_mm": r.k_out_N_per_mm,
            "strain_energy_mJ": r.strain_energy_mJ * scale**2,
            "hinge_stress_MPa": {h: v.neck_MPa * scale for h, v in s.items()},
            "hinge_peak_stress_MPa": peak, **_utilisation(design, peak),
            **knee_motion_beam(design, model, r)}


def _utilisation(design: Design, peak_MPa: dict | None) -> dict:
    """``peak_stress_MPa`` (the largest hinge peak, MPa), the hinge it is at
    (``peak_stress_hinge``) and ``stress_utilisation`` (peak / the material's allowable
    stress, DESIGN section 14; the first and last as ``dacm solve --json`` names them); None
    without peaks."""
    if not peak_MPa:
        return {"peak_stress_MPa": None, "peak_stress_hinge": None, "stress_utilisation": None}
    hinge = max(peak_MPa, key=peak_MPa.get)
    return {"peak_stress_MPa": peak_MPa[hinge], "peak_stress_hinge": hinge,
            "stress_utilisation": peak_MPa[hinge] / design.material.allowable_stress_MPa}


def verify_design(design: Design, mesh: str | float = "default", plane_strain: bool = False,
                  nonlinear: bool = False, target_output_mm: float = 1.0,
                  kerf_mm: float | None = None, clamp: str = "bottom edge",
                  punch_width_mm: float | None = None, nonlinear_meshes: int = 1) -> Verification:
    """Continuum FE (three meshes, Richardson) and beam model of one design as cut with
    ``kerf_mm`` (default the design's own ``kerf_mm``; 0: the drawing), compared at
    ``target_output_mm`` (linear: both in the linear limit, scaled to it), the input pushed
    through a punch ``punch_width_mm`` wide (default :func:`geometry.topology.input_contact_mm`;
    see :data:`~geometry.topology.INPUT_CONTACT_MM`).

    Nonlinear, with ``nonlinear_meshes`` = 1 (the default), the three meshes are solved
    linear and only the coarsest nonlinear: each FE value is the linear study's, times the
    nonlinear over the linear value of that coarsest mesh (the mesh's relative error taken as
    the linear study's: the continuum table's method; on sample B as cut at the default
    level within 0.04 % of three nonlinear meshes on A, k_out and SE, 1.1 % on the root
    peaks, in a sixth of the time; ``fe`` is that nonlinear state). With 3, all three are
    solved nonlinear."""
    if nonlinear_meshes not in (1, 3):
        raise SensorInputError(f"nonlinear_meshes = {nonlinear_meshes!r}: must be 1 or 3")
    if kerf_mm is not None:
        design = design.replace(kerf_mm=kerf_mm)

    punch_width_mm = input_contact_mm(design) if punch_width_mm is None else punch_width_mm  # one width for both models
    one = nonlinear and nonlinear_meshes == 1
    options = dict(plane_strain=plane_strain, target_output_mm=target_output_mm, clamp=clamp,
                   punch_width_mm=punch_width_mm)
    runs, conv = convergence_study(design, mesh, nonlinear=nonlinear and not one, **options)
    conv["hinge_peak_stress_MPa"] = {h: richardson([r.hinge_stress_MPa[h] for r in runs])
                                     for h in runs[-1].hinge_stress_MPa}
    knees = [knee_motion_fe(design, r) for r in runs]
    conv.update({q: richardson([k[q] for k in knees]) for q in KNEE_MOTION})
    fe_summary = {**_fe_fields(runs[-1], knees[-1]), **{q: conv[q].extrapolated for q in CONVERGED + KNEE_MOTION}}
    fe = runs[-1]
    if one:
        fe = verify(design, mesh=runs[0].elements_across, nonlinear=True, **options)
        fe_summary = _transferred(fe_summary, _fe_fields(runs[0], knees[0]),
                                  _fe_fields(fe, knee_motion_fe(design, fe)))
    # the fillets' peak converges; at sharp roots it is singular: no verdict

    fe_summary.update(_utilisation(design, fe_summary["hinge_peak_stress_MPa"] if root_radius_mm(design) > 0 else None))
    beam = _beam_side(design, target_output_mm, nonlinear, punch_width_mm)
    if "unstable" in beam:
        return Verification(design, str(mesh), fe, tuple(runs), conv, fe_summary, beam, {})
    errors = {q: relative_error_pct(beam[q], fe_summary[q]) for q in CONVERGED + KNEE_MOTION}
    errors["hinge_stress_MPa"] = {h: relative_error_pct(beam["hinge_stress_MPa"][h], v)
                                  for h, v in fe_summary["hinge_stress_MPa"].items()}
    return Verification(design, str(mesh), fe, tuple(runs), conv, fe_summary, beam, errors)


def _fe_fields(run: ContinuumResult, knee: dict) -> dict:
    """One mesh's values of the FE summary (:class:`Verification`): A, k_out, SE, the knee's
    motion (``knee``: :func:`knee_motion_fe` of the run) and per hinge the neck stress, the
    peak and where it sits."""
    return {**{q: getattr(run, q) for q in CONVERGED}, **knee,
            "hinge_stress_MPa": dict(run.hinge_neck_stress_MPa),
            "hinge_peak_stress_MPa": dict(run.hinge_stress_MPa),
            "hinge_peak_station_mm": dict(run.hinge_peak_station_mm)}


def _transferred(linear: dict, linear_coarse: dict, nonlinear_coarse: dict) -> dict:
    """The FE summary of a nonlinear state solved on the coarsest mesh only: each value of
    the linear summary times the nonlinear over the linear value on that mesh (per hinge for
    the stresses; the peaks' stations and the knee's fit residual are the nonlinear mesh's)."""
    def ratio(lin, lin0, nl0):
        return lin * nl0 / lin0 if lin0 else nl0

    out = dict(nonlinear_coarse)
    for key, value in linear.items():
        if key in ("hinge_peak_station_mm", "knee_fit_residual"):
            continue
        if isinstance(value, dict):
            out[key] = {h: ratio(v, linear_coarse[key][h], nonlinear_coarse[key][h]) for h, v in value.items()}
        else:
            out[key] = ratio(value, linear_coarse[key], nonlinear_coarse[key])
    return out


def verification_to_dict(v: Verification) -> dict:
    """The JSON form of a :class:`Verification` (keys ``fe``, ``beam``, ``errors_pct``,
    ``convergence``, ``mesh``, ``options``, ``stability``: null when linear, else whether the
    nonlinear state at the target is stable, that of ``fe``; ``options["nonlinear_meshes"]``
    says how many meshes were solved nonlinear)."""
    def number(x):  # JSON has no NaN: an undefined value is null
        return None if isinstance(x, float) and math.isnan(x) else x

    def side(d):
        return {k: {str(h): number(y) for h, y in x.items()} if isinstance(x, dict) else number(x)
                for k, x in d.items()}

    def study(c):
        return {"values": list(c.values), "elements_across": [r.elements_across for r in v.runs],
                "order": number(c.order), "extrapolated": c.extrapolated, "error_pct": number(c.error_pct)}

    fe = v.fe
    return {
        "design": v.design.name,
        "kerf_mm": v.design.kerf_mm,
        "profile": cut_note(v.design.kerf_mm),
        "fe": side(v.fe_summary),
        "beam": side(v.beam),
        "errors_pct": side(v.errors_pct),
        "convergence": {q: {str(h): study(x) for h, x in c.items()} if isinstance(c, dict) else study(c)
                        for q, c in v.convergence.items()},
        "mesh": {"level": v.mesh, "elements_across_hinge": fe.elements_across,
                 "hinge_element_size_mm": fe.size_mm, "elements": fe.n_elements, "dofs": fe.n_dofs},
        "options": {"plane_strain": fe.plane_strain, "nonlinear": fe.nonlinear,
                    "nonlinear_meshes": (3 if v.runs[-1].nonlinear else 1) if fe.nonlinear else None,
                    "output_travel_mm": fe.output_travel_mm, "punch_width_mm": fe.punch_width_mm},
        "stability": None if fe.stable is None else {
            "stable": fe.stable, "negative_modes": fe.negative_modes},
    }
