"""An independent planar large-deflection frame model, used only to check ``sensor.mechanics.solver``.

Method (deliberately different from the solver's one-element-per-member co-rotational
Castigliano stiffness): every compliant member is split into ``n`` straight sub-segments of a
geometrically exact (Simo-Reissner) beam with linear interpolation and one-point (midpoint)
integration. With node positions x and section rotations theta, a segment i-j of reference
length h and reference angle beta has, at its midpoint angle phi = beta + (theta_i + theta_j)/2,

    axial   eps   = (x_j - x_i) . t(phi) / h - 1
    shear   gamma = (x_j - x_i) . n(phi) / h
    bending kappa = (theta_j - theta_i) / h

and strain energy h/2 (EA eps^2 + k G A gamma^2 + EI kappa^2), k = 5/6 (the rectangle's shear
correction, the inverse of the form factor 6/5), G = E / 2(1 + nu), plus the material law's
cubic term, St Venant-Kirchhoff's as the continuum's, h (3/2 (1 - nu) N kappa^2 I / A +
N^3 / (2 E^2 A^2)), N = EA eps (A, I the segment's own section, without the axial spread:
the same law as the solver's, in the section strains). This is exact in large
rotation; as n grows it tends to the Timoshenko beam (error O(1/n^2), one-point integration
keeps it free of shear locking). A member with a thickness profile has segments of its mean
axial and bending compliance per length, their nodes on the sections' centroid line (the
profile's e, to the left of the chord), so an axial force bends the offset part by the
segments' geometry alone. The profile's sections are square to the chord: a segment's
reference length h is its share of the chord and its reference angle beta the chord's, and
its reference strains are subtracted (the centroid's rise across it, de, makes the
reference state's gamma de / h), so a rigid motion strains nothing and its compliance is
its share's however steeply the centroid line runs; where an end section's centroid is off
the member's end node (a leaning root's, geometry.topology.ROOT_COUPLING_PER_LEAN), a rigid
arm joins them. A member's axial spread (geometry.topology.axial_spread) adds to its
segments' axial compliance, evenly along it. Members of kind ``rigid`` are exactly rigid: the nodes they
join form rigid bodies with three unknowns each. A dead load F along the input direction acts
at the input node, and at equilibrium the total potential energy

    Pi(q) = U(q) - F d_in . u_in(q)

is stationary: dPi/dq = 0 is solved by Newton's method with the analytic gradient and
Hessian (sparse LU, ``scipy.sparse.linalg.splu``), raising the load in steps. Stationary
rather than minimal: sample-b's symmetric state at 1 mm output lies past a sideways-sway
bifurcation of the frame under a dead load, where it is a saddle of Pi (a minimiser leaves
it). Only ``geometry.topology.BeamModel`` is read, and the inertia count of a sparse matrix
(``sensor.mechanics.continuum.negative_eigenvalues``); nothing comes from the solver under
test.
Units: mm, N, MPa, mJ (N mm).
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
from scipy.sparse.csgraph import connected_components
from scipy.sparse.linalg import splu

from geometry.topology import BeamModel
from sensor.mechanics.continuum import negative_eigenvalues

SHEAR_CORRECTION = 5.0 / 6.0  # rectangle; the inverse of the form factor 6/5


@dataclass(frozen=True, eq=False)
class Frame:
    """The discretised frame: nodes (model nodes first, then sub-segment nodes), segments,
    and rigid bodies; each node belongs to one body (a lone node is a body of its own)."""

    X: np.ndarray          # (N, 2) reference node positions, mm
    seg: np.ndarray        # (s, 2) node indices of each segment
    h: np.ndarray          # (s,) reference segment length (its share of the chord), mm
    beta: np.ndarray       # (s,) reference section angle (the chord's), rad
    rise: np.ndarray       # (s,) the centroid line's rise across the segment over h
    stiff: np.ndarray      # (s, 3) EA, kGA (N), EI (N mm^2)
    cubic: np.ndarray      # (s, 2) the cubic term's 3/2 (1 - nu) I / A (mm^2), 1 / (2 E^2 A^2) (N^-2)
    body: np.ndarray       # (N,) body of each node
    r0: np.ndarray         # (N, 2) node offset from its body's reference node, mm
    dof: np.ndarray        # (nb, 3) unknown index of each body's ux, uy, theta; -1 if held
    n_dof: int
    input_node: int
    input_dir: np.ndarray  # (2,)
    output_node: int
    output_dir: np.ndarray  # (2,)


@dataclass(frozen=True)
class FrameResult:
    """Equilibrium under a dead input load: port travels (mm), A, k_out (N/mm), U (mJ)."""

    force_N: float
    input_travel_mm: float
    output_travel_mm: float
    strain_energy_mJ: float
    gradient_norm: float   # |dPi/dq| at the returned state (N and N mm)
    negative_modes: int    # negative eigenvalues of the Hessian of Pi (0: a minimum)
    n_dof: int
    iterations: int        # Newton iterations over all load steps

    @property
    def stable(self) -> bool:
        return self.negative_modes == 0

    @property
    def amplification(self) -> float:
        return self.output_travel_mm / self.input_travel_mm

    @property
    def k_out_N_per_mm(self) -> float:
        return self.force_N / self.output_travel_mm


def segment_thickness(profile, t: float, n_segments: int, samples: int = 64):
    """Equivalent thicknesses of ``n_segments`` equal segments of a member: (axial, bending)
    such that t_axial^-1 and t_bend^-3 are the segment means of t(s)^-1 and t(s)^-3 over
    ``samples`` midpoints (the segment's axial and bending compliances per length); a
    member without a profile is uniform."""
    if profile is None:
        return np.full(n_segments, t), np.full(n_segments, t)
    length = profile[-1, 0]
    x = (np.arange(n_segments * samples) + 0.5) * length / (n_segments * samples)
    tx = np.interp(x, profile[:, 0], profile[:, 1]).reshape(n_segments, samples)
    return 1.0 / (1.0 / tx).mean(axis=1), ((tx**-3.0).mean(axis=1)) ** (-1.0 / 3.0)


def centroid_offset(profile, s: np.ndarray) -> np.ndarray:
    """The sections' centroid offset e (mm, to the left of the chord) at fractions s of a
    member's length (0 without a profile or its e column)."""
    if profile is None or profile.shape[1] < 3:
        return np.zeros_like(s)
    return np.interp(s * profile[-1, 0], profile[:, 0], profile[:, 2])


def discretise(model: BeamModel, n_segments: int) -> Frame:
    """Split each compliant member of ``model`` into ``n_segments`` equal segments."""
    if not (isinstance(n_segments, int) and n_segments >= 1):
        raise ValueError(f"n_segments = {n_segments!r}: must be an integer >= 1")
    X = [np.asarray(model.nodes, dtype=float)]
    n0 = len(model.nodes)
    seg, stiff, cubic, share, angle, rise = [], [], [], [], [], []
    G = model.E_MPa / (2.0 * (1.0 + model.nu))
    rigid = np.array([k == "rigid" for k in model.member_kind])
    flex = np.flatnonzero(~rigid)
    offsets = []  # rigid links from a member's end node to its centroid there, where e != 0
    count = n0
    for k in flex:
        (a, b), t, w = model.member_nodes[k], model.thickness_mm[k], model.depth_mm[k]
        # the segments follow the sections' centroids: e (mm) to the left of the chord
        chord = model.nodes[b] - model.nodes[a]
        left = np.array([-chord[1], chord[0]]) / np.linalg.norm(chord)
        s = np.linspace(0.0, 1.0, n_segments + 1)
        e = centroid_offset(model.profile_mm[k], s)
        points = (1 - s[:, None]) * model.nodes[a] + s[:, None] * model.nodes[b] + e[:, None] * left
        X.append(points[1:-1])
        chain = [a, *range(count, count + n_segments - 1), b]
        count += n_segments - 1
        for end in (0, -1):
            if e[end] != 0.0:  # the end's section sits off its node: a rigid arm reaches it
                X.append(points[[end]])
                offsets.append((chain[end], count))
                chain[end] = count
                count += 1
        h = np.linalg.norm(chord) / n_segments
        share.append(np.full(n_segments, h))
        angle.append(np.full(n_segments, np.arctan2(chord[1], chord[0])))
        rise.append(np.diff(e) / h)
        seg.append(np.column_stack([chain[:-1], chain[1:]]))
        t_axial, t_bend = segment_thickness(model.profile_mm[k], t, n_segments)
        # the member's axial spread (geometry.topology.axial_spread), spread along it
        area = w / (1.0 / t_axial + model.axial_spread[k] / np.linalg.norm(chord))
        stiff.append(np.column_stack([model.E_MPa * area, SHEAR_CORRECTION * G * area,
                                      model.E_MPa * w * t_bend**3 / 12.0]))
        cubic.append(np.column_stack([1.5 * (1 - model.nu) * t_bend**3 / (12.0 * t_axial),
                                      0.5 / (model.E_MPa * w * t_axial) ** 2]))
    X = np.concatenate(X)
    seg = np.concatenate(seg)
    N = len(X)
    # rigid bodies: connected components of the graph of rigid members
    rm = np.concatenate([model.member_nodes[rigid], np.array(offsets, dtype=int).reshape(-1, 2)])
    graph = sp.coo_matrix((np.ones(len(rm)), (rm[:, 0], rm[:, 1])), shape=(N, N))
    nb, body = connected_components(graph, directed=False)
    held = np.zeros((nb, 3), dtype=bool)
    ref = np.full(nb, -1)
    for node, dofs in model.supports:
        c = body[node]
        if ref[c] >= 0 and ref[c] != node:
            raise ValueError(f"support at node {node}: its rigid body already has a support node")
        ref[c] = node
        for name in dofs:
            held[c, ("x", "y", "rz").index(name)] = True
    for c in np.flatnonzero(ref < 0):
        ref[c] = np.flatnonzero(body == c)[0]
    dof = -np.ones((nb, 3), dtype=int)
    dof[~held] = np.arange(int((~held).sum()))
    return Frame(X, seg, np.concatenate(share), np.concatenate(angle), np.concatenate(rise), np.concatenate(stiff), np.concatenate(cubic), body, X - X[ref[body]], dof, int((~held).sum()),
                 int(model.input_node), np.asarray(model.input_direction, float),
                 int(model.output_node), np.asarray(model.output_direction, float))


def node_state(frame: Frame, q: np.ndarray):
    """Node displacements u (N, 2), rotations theta (N,), and the turned offsets R r0."""
    qb = np.zeros(frame.dof.shape)
    free = frame.dof >= 0
    qb[free] = q[frame.dof[free]]
    qn = qb[frame.body]
    th = qn[:, 2]
    c, s = np.cos(th), np.sin(th)
    rr = np.column_stack([c * frame.r0[:, 0] - s * frame.r0[:, 1],
                          s * frame.r0[:, 0] + c * frame.r0[:, 1]])
    return qn[:, :2] + rr - frame.r0, th, rr


def _jacobian(frame: Frame, rr: np.ndarray) -> sp.csr_matrix:
    """d(node x, y, theta) / dq, (3N, n_dof), at turned offsets rr."""
    N = len(frame.X)
    rows, cols, vals = [], [], []
    nodes = np.arange(N)
    for k in (0, 1):
        d = frame.dof[frame.body, k]
        m = d >= 0
        rows.append(3 * nodes[m] + k); cols.append(d[m]); vals.append(np.ones(m.sum()))
    d = frame.dof[frame.body, 2]
    m = d >= 0
    for comp, v in ((0, -rr[:, 1]), (1, rr[:, 0]), (2, np.ones(N))):
        rows.append(3 * nodes[m] + comp); cols.append(d[m]); vals.append(v[m])
    return sp.csr_matrix((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))),
                         shape=(3 * N, frame.n_dof))


def _segments(frame: Frame, u: np.ndarray, th: np.ndarray, order: int):
    """Strain energy, and (order >= 1) its gradient (s, 6), (order 2) Hessian (s, 6, 6), per
    segment, in the node variables [x_i, y_i, theta_i, x_j, y_j, theta_j]."""
    i, j = frame.seg[:, 0], frame.seg[:, 1]
    h = frame.h
    EA, GAk, EI = frame.stiff.T
    tm = 0.5 * (th[i] + th[j])
    phi = frame.beta + tm
    t = np.column_stack([np.cos(phi), np.sin(phi)])
    n = np.column_stack([-t[:, 1], t[:, 0]])
    du = (u[j] - u[i]) / h[:, None]
    b = frame.rise
    # the reference segment is h (t(beta) + b n(beta)): its projections are cos(tm) + b sin(tm)
    # and b cos(tm) - sin(tm), less the reference strains (0 and b); cos - 1 is formed
    # without cancellation
    cm1 = -2.0 * np.sin(0.5 * tm) ** 2
    eps = cm1 + b * np.sin(tm) + np.sum(du * t, 1)
    gam = -np.sin(tm) + b * cm1 + np.sum(du * n, 1)
    kap = (th[j] - th[i]) / h
    alpha, beta = frame.cubic.T
    N_ = EA * eps
    energy = 0.5 * h * (EA * eps**2 + GAk * gam**2 + EI * kap**2) + h * (alpha * N_ * kap**2 + beta * N_**3)
    if order == 0:
        return energy, None, None
    z = np.zeros_like(h)
    one_plus_eps = 1.0 + eps
    de = np.column_stack([-t[:, 0] / h, -t[:, 1] / h, 0.5 * (gam + b),
                          t[:, 0] / h, t[:, 1] / h, 0.5 * (gam + b)])
    dg = np.column_stack([-n[:, 0] / h, -n[:, 1] / h, -0.5 * one_plus_eps,
                          n[:, 0] / h, n[:, 1] / h, -0.5 * one_plus_eps])
    dk = np.column_stack([z, z, -1 / h, z, z, 1 / h])
    # section forces: the axial force and moment with the cubic term's
    Nc = N_ + EA * (alpha * kap**2 + 3 * beta * N_**2)
    V_, Mc = GAk * gam, EI * kap + 2 * alpha * N_ * kap
    grad = h[:, None] * (Nc[:, None] * de + V_[:, None] * dg + Mc[:, None] * dk)
    if order == 1:
        return energy, grad, None
    # second derivatives of eps, gamma: dt/dphi = n, dn/dphi = -t, dphi/dtheta = 1/2
    d2e = np.zeros((len(h), 6, 6))
    d2g = np.zeros((len(h), 6, 6))
    for a, sign in ((0, -1.0), (3, 1.0)):
        for th_idx in (2, 5):
            for c in (0, 1):
                d2e[:, a + c, th_idx] = d2e[:, th_idx, a + c] = sign * 0.5 * n[:, c] / h
                d2g[:, a + c, th_idx] = d2g[:, th_idx, a + c] = -sign * 0.5 * t[:, c] / h
    for p in (2, 5):
        for r in (2, 5):
            d2e[:, p, r] = -0.25 * one_plus_eps
            d2g[:, p, r] = -0.25 * (gam + b)
    def outer(v):
        return v[:, :, None] * v[:, None, :]

    hess = h[:, None, None] * (
        (EA + 6 * beta * EA**2 * N_)[:, None, None] * outer(de) + Nc[:, None, None] * d2e
        + GAk[:, None, None] * outer(dg) + V_[:, None, None] * d2g
        + (EI + 2 * alpha * N_)[:, None, None] * outer(dk)
        + (2 * alpha * EA * kap)[:, None, None] * (de[:, :, None] * dk[:, None, :] + dk[:, :, None] * de[:, None, :]))
    return energy, grad, hess


def _segment_index(frame: Frame) -> np.ndarray:
    """(s, 6) positions of each segment's node variables in the (3N,) node vector."""
    return np.concatenate([3 * frame.seg[:, :1] + np.arange(3),
                           3 * frame.seg[:, 1:] + np.arange(3)], 1)


def _node_vector(frame: Frame, per_seg: np.ndarray) -> np.ndarray:
    """Scatter per-segment node-variable gradients (s, 6) into a (3N,) vector."""
    return np.bincount(_segment_index(frame).ravel(), per_seg.ravel(), minlength=3 * len(frame.X))


def potential(frame: Frame, q: np.ndarray, force: float):
    """Total potential Pi (mJ) and its gradient dPi/dq."""
    u, th, rr = node_state(frame, q)
    energy, grad_s, _ = _segments(frame, u, th, 1)
    g = _node_vector(frame, grad_s)
    g[3 * frame.input_node: 3 * frame.input_node + 2] -= force * frame.input_dir
    pi = energy.sum() - force * frame.input_dir @ u[frame.input_node]
    return pi, _jacobian(frame, rr).T @ g


def hessian(frame: Frame, q: np.ndarray, force: float) -> sp.csc_matrix:
    """d^2 Pi / dq^2 (sparse): J^T H J plus the turning of rigid-body offsets."""
    u, th, rr = node_state(frame, q)
    _, grad_s, hess_s = _segments(frame, u, th, 2)
    idx = _segment_index(frame)
    rows = np.repeat(idx, 6, axis=1).ravel()
    cols = np.tile(idx, (1, 6)).ravel()
    n3 = 3 * len(frame.X)
    H = sp.csr_matrix((hess_s.ravel(), (rows, cols)), shape=(n3, n3))
    J = _jacobian(frame, rr)
    # d^2 x_node / d theta_body^2 = -R r0: weighted by the node-force gradient
    g = _node_vector(frame, grad_s).reshape(-1, 3)
    g[frame.input_node, :2] -= force * frame.input_dir
    d = frame.dof[frame.body, 2]
    m = d >= 0
    turn = np.bincount(d[m], -np.sum(g[m, :2] * rr[m], 1), minlength=frame.n_dof)
    return (J.T @ H @ J + sp.diags(turn)).tocsc()


def solve_dead_load(model: BeamModel, force_N: float, n_segments: int = 16,
                    load_steps: int = 4, max_iterations: int = 30) -> FrameResult:
    """Equilibrium of ``model`` under a dead load ``force_N`` along the input direction.

    The load is raised in ``load_steps`` equal steps; at each, Newton's method on
    dPi/dq = 0 (sparse LU of the analytic Hessian) starts from the previous state and stops
    when its step falls to rounding level (1e-12 of the largest unknown).
    """
    if not (np.isfinite(force_N) and force_N > 0):
        raise ValueError(f"force_N = {force_N!r}: must be a positive finite number")
    if not (isinstance(load_steps, int) and load_steps >= 1):
        raise ValueError(f"load_steps = {load_steps!r}: must be an integer >= 1")
    frame = discretise(model, n_segments)
    q = np.zeros(frame.n_dof)
    iterations = 0
    for level in np.linspace(force_N / load_steps, force_N, load_steps):
        for _ in range(max_iterations):
            step = splu(hessian(frame, q, level)).solve(potential(frame, q, level)[1])
            q = q - step
            iterations += 1
            if np.abs(step).max() <= 1e-12 * max(np.abs(q).max(), 1e-3):
                break
        else:
            raise RuntimeError(f"reference frame: Newton did not converge at {level:.4g} N in "
                               f"{max_iterations} iterations (last step {np.abs(step).max():.2e})")
    return _result(frame, q, force_N, iterations)


def _result(frame: Frame, q: np.ndarray, force: float, iterations: int) -> FrameResult:
    u, th, _ = node_state(frame, q)
    energy, _, _ = _segments(frame, u, th, 0)
    _, g = potential(frame, q, force)
    return FrameResult(force, float(frame.input_dir @ u[frame.input_node]),
                       float(frame.output_dir @ u[frame.output_node]), float(energy.sum()),
                       float(np.linalg.norm(g)), negative_eigenvalues(hessian(frame, q, force)),
                       frame.n_dof, iterations)


def split_members(model: BeamModel, n: int) -> BeamModel:
    """The same frame with every compliant member split into ``n`` equal members in a row.

    For refinement studies of a solver that uses one element per member; the first piece
    keeps the member's hinge number.
    """
    if not (isinstance(n, int) and n >= 1):
        raise ValueError(f"n = {n!r}: must be an integer >= 1")
    nodes = [np.asarray(model.nodes, dtype=float)]
    rows = []  # (start, end, member index, first piece)
    count = len(model.nodes)
    for k, ((a, b), kind) in enumerate(zip(model.member_nodes, model.member_kind)):
        if kind == "rigid" or n == 1:
            rows.append((a, b, k, True))
            continue
        s = np.linspace(0.0, 1.0, n + 1)[1:-1, None]
        nodes.append((1 - s) * model.nodes[a] + s * model.nodes[b])
        chain = [a, *range(count, count + n - 1), b]
        count += n - 1
        rows += [(chain[i], chain[i + 1], k, i == 0) for i in range(n)]
    start, end, src, first = (np.array(c) for c in zip(*rows))
    pieces = np.array([1 if model.member_kind[k] == "rigid" else n for k in src])  # a member's share of its spread
    piece = np.zeros(len(src), dtype=int)
    for i in range(1, len(src)):
        piece[i] = piece[i - 1] + 1 if src[i] == src[i - 1] else 0
    return dataclasses.replace(
        model, nodes=np.concatenate(nodes), member_nodes=np.column_stack([start, end]),
        member_kind=tuple(model.member_kind[k] for k in src),
        thickness_mm=model.thickness_mm[src], depth_mm=model.depth_mm[src],
        hinge_number=np.where(first, model.hinge_number[src], 0),
        member_name=tuple(model.member_name[k] for k in src),
        profile_mm=tuple(_piece_profile(model.profile_mm[k], i, n if model.member_kind[k] != "rigid" else 1)
                         for k, i in zip(src, piece)),
        neck_mm=None, root_radius_mm=None, axial_spread=model.axial_spread[src] / pieces)


def _piece_profile(profile, i: int, n: int):
    """The part of a member's thickness profile on its i-th of n equal pieces, from 0."""
    if profile is None:
        return None
    length = profile[-1, 0]
    lo, hi = i * length / n, (i + 1) * length / n
    inside = profile[(profile[:, 0] > lo) & (profile[:, 0] < hi), 0]
    s = np.concatenate([[lo], inside, [hi]])
    return np.column_stack([s - lo] + [np.interp(s, profile[:, 0], profile[:, c]) for c in range(1, profile.shape[1])])
