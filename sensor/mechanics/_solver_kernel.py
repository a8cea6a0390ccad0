"""Compiled inner loop of the chain-algorithm solver (thesis section 6.2.1, eqs 80-86).

One design at a time: the member forces and tangents in their co-rotational chord frames
(eqs 80-82 with the bowing term), their assembly on the rigid bodies' dofs, and Newton's
equilibrium iterations of one load increment (eqs 85-86 with the loop closure). The linear
systems are solved by Gaussian elimination with partial pivoting that skips the zeros of the
banded stiffness matrix (:func:`sensor.mechanics.solver.prepare` numbers the bodies so that
the band is narrow). :mod:`sensor.mechanics.solver` drives the increments, checks every
increment and builds the results; the formulas are explained there. Units: mm, N, N mm.
"""

from __future__ import annotations

import math
from collections import namedtuple

import numpy as np
from numba import njit

TWO_PI = 2.0 * math.pi
#: Newton statuses of one design at one increment.
CONVERGED, NOT_CONVERGED, SINGULAR = 0, 1, 2
#: Intermediate increments accept a state after a correction from a residual below this
#: (Newton's quadratic convergence leaves ~1e-8; the next increment starts from there).
EARLY_ACCEPT = 1e-4

#: Scratch arrays of one design's evaluation and linear solve (reused across designs).
Work = namedtuple("Work", "u th rho defo qf f Ke Bm KB z r F Kg g_in g_out W x L")


def work(n_nodes: int, n_dof: int) -> Work:
    """Scratch arrays for a topology of n_nodes nodes and n_dof reduced dofs (the tangent Kg
    starts zero: :func:`_evaluate` clears only its envelope)."""
    e = np.empty
    return Work(e((n_nodes, 2)), e(n_nodes), e((n_nodes, 2)), e(3), e(3), e(6), e((6, 6)),
                e((3, 6)), e((3, 6)), e(6), e(6), e(n_dof), np.zeros((n_dof, n_dof)), e(n_dof),
                e(n_dof), e((n_dof + 1, n_dof + 2)), e(n_dof), np.zeros((n_dof, n_dof)))


@njit(cache=True, error_model="numpy")
def _wrap(a):
    return (a + math.pi) % TWO_PI - math.pi


@njit(cache=True, error_model="numpy")
def node_state(q, body_of_node, r0, u, th, rho):
    """Displacements u (n, 2), rotations th (n,) and current offsets rho (n, 2) of the nodes
    from the bodies' translations and rotations q (c, 3); cos - 1 without cancellation."""
    for i in range(body_of_node.shape[0]):
        b = body_of_node[i]
        t = q[b, 2]
        s = math.sin(t)
        h = math.sin(t / 2)
        cm1 = -2.0 * (h * h)
        tx = cm1 * r0[i, 0] - s * r0[i, 1]
        ty = s * r0[i, 0] + cm1 * r0[i, 1]
        u[i, 0] = q[b, 0] + tx
        u[i, 1] = q[b, 1] + ty
        th[i] = t
        rho[i, 0] = r0[i, 0] + tx
        rho[i, 1] = r0[i, 1] + ty


@njit(cache=True, error_model="numpy", inline="always")
def _cubic(n, s00, s11, s12, s22, ai, aj, Si, Sj, k1i, k1j, k2i, k2j):
    """Entry (i, j) of the Hessian of n S (see :func:`element`): ai Sj + Si aj + n d2S_ij,
    a = dn, S_i = dS, k1 = dm1, k2 = dm2 along the deformations i and j."""
    return ai * Sj + Si * aj + n * (2 * s11 * k1i * k1j + s12 * (k1i * k2j + k2i * k1j)
                                    + 2 * s22 * k2i * k2j + 2 * s00 * ai * aj)


# inlined into its callers (numba IR): a call passes the 19 arrays as ~150 scalars, and the
# kernel runs it 26 times an evaluation
@njit(cache=True, error_model="numpy", inline="always")
def element(k, ea, eb, d0, L0, beta0, Kn, Bw, u, th, rho, defo, qf, f, K, Bm, KB, z, r):
    """Member k: chord-frame deformations defo (stretch, theta_a, theta_b), conjugate forces
    qf (N, M_a, M_b), node forces f (6,) and tangent K (6, 6) on the dofs of the two bodies
    (x, y, rotation of the body at a, then at b). Returns the member's strain energy, mJ."""
    a, b = ea[k], eb[k]
    du0 = u[b, 0] - u[a, 0]
    du1 = u[b, 1] - u[a, 1]
    dx = d0[k, 0] + du0
    dy = d0[k, 1] + du1
    Ln = math.sqrt(dx * dx + dy * dy)
    stretch = (2 * (d0[k, 0] * du0 + d0[k, 1] * du1) + du0 * du0 + du1 * du1) / (Ln + L0[k])
    c, s = dx / Ln, dy / Ln
    alpha = _wrap(math.atan2(s, c) - beta0[k])
    t1 = _wrap(th[a] - alpha)
    t2 = _wrap(th[b] - alpha)
    defo[0], defo[1], defo[2] = stretch, t1, t2
    # bowing: the axis is longer than the chord by p11 t1^2 + p12 t1 t2 + p22 t2^2 (for a
    # uniform member L0 (2 t1^2 - t1 t2 + 2 t2^2) / 30; Bw holds each member's p), and the
    # axial force n changes the bending stiffness at second order too: strain energy
    # n^2 (c11 t1^2 + c12 t1 t2 + c22 t2^2) (Bw[3:6]; -L^3 (11, -13, 11) / 12600 EI
    # for a uniform member, the n^2 term of the stability functions), with n^2 (d1 t1 + d2 t2)
    # where an oblique root's centroid leaves the chord (Bw[6:8]; zero on a uniform member).
    # The material law's cubic term (St Venant-Kirchhoff's, solver.material_coefficients) is
    # n S, S = s11 m1^2 + s12 m1 m2 + s22 m2^2 + s00 n^2 (Bw[8:12])
    p11, p12, p22 = Bw[k, 0], Bw[k, 1], Bw[k, 2]
    c11, c12, c22 = Bw[k, 3], Bw[k, 4], Bw[k, 5]
    d1, d2 = Bw[k, 6], Bw[k, 7]
    s11, s12, s22, s00 = Bw[k, 8], Bw[k, 9], Bw[k, 10], Bw[k, 11]
    e0 = stretch + p11 * t1 * t1 + p12 * t1 * t2 + p22 * t2 * t2
    kn = Kn[k]
    a0, a1, a2 = kn[0, 0], kn[0, 1], kn[0, 2]
    n = a0 * e0 + a1 * t1 + a2 * t2
    m1 = kn[1, 0] * e0 + kn[1, 1] * t1 + kn[1, 2] * t2
    m2 = kn[2, 0] * e0 + kn[2, 1] * t1 + kn[2, 2] * t2
    g = c11 * t1 * t1 + c12 * t1 * t2 + c22 * t2 * t2 + d1 * t1 + d2 * t2
    g1, g2 = 2 * c11 * t1 + c12 * t2 + d1, c12 * t1 + 2 * c22 * t2 + d2
    S = s11 * m1 * m1 + s12 * m1 * m2 + s22 * m2 * m2 + s00 * n * n
    sm1, sm2, sn = 2 * s11 * m1 + s12 * m2, s12 * m1 + 2 * s22 * m2, 2 * s00 * n
    # dS/d(e0, t1, t2), through m1, m2 and n
    S0 = sm1 * kn[1, 0] + sm2 * kn[2, 0] + sn * a0
    S1 = sm1 * kn[1, 1] + sm2 * kn[2, 1] + sn * a1
    S2 = sm1 * kn[1, 2] + sm2 * kn[2, 2] + sn * a2
    ng2 = 2 * n * g
    q0 = n + ng2 * a0 + S * a0 + n * S0
    q1 = m1 + ng2 * a1 + n * n * g1 + S * a1 + n * S1
    q2 = m2 + ng2 * a2 + n * n * g2 + S * a2 + n * S2
    b1, b2 = 2 * p11 * t1 + p12 * t2, p12 * t1 + 2 * p22 * t2
    qf[0], qf[1], qf[2] = q0, q1 + q0 * b1, q2 + q0 * b2
    energy = 0.5 * (e0 * n + t1 * m1 + t2 * m2) + n * n * g + n * S
    # Hessian h of the energy in (e0, t1, t2): Kn, plus the n^2 term's
    # 2 g kn0 kn0^T + 2 n (kn0 dg^T + dg kn0^T) + n^2 d2g, dg = (0, g1, g2), plus n S's
    # kn0 dS^T + dS kn0^T + n d2S
    h00 = a0 + 2 * g * a0 * a0 + _cubic(n, s00, s11, s12, s22, a0, a0, S0, S0, kn[1, 0], kn[1, 0], kn[2, 0], kn[2, 0])
    h01 = (a1 + 2 * g * a0 * a1 + 2 * n * a0 * g1
           + _cubic(n, s00, s11, s12, s22, a0, a1, S0, S1, kn[1, 0], kn[1, 1], kn[2, 0], kn[2, 1]))
    h02 = (a2 + 2 * g * a0 * a2 + 2 * n * a0 * g2
           + _cubic(n, s00, s11, s12, s22, a0, a2, S0, S2, kn[1, 0], kn[1, 2], kn[2, 0], kn[2, 2]))
    h11 = (kn[1, 1] + 2 * g * a1 * a1 + 4 * n * a1 * g1 + 2 * n * n * c11
           + _cubic(n, s00, s11, s12, s22, a1, a1, S1, S1, kn[1, 1], kn[1, 1], kn[2, 1], kn[2, 1]))
    h22 = (kn[2, 2] + 2 * g * a2 * a2 + 4 * n * a2 * g2 + 2 * n * n * c22
           + _cubic(n, s00, s11, s12, s22, a2, a2, S2, S2, kn[1, 2], kn[1, 2], kn[2, 2], kn[2, 2]))
    h12 = (kn[1, 2] + 2 * g * a1 * a2 + 2 * n * (a1 * g2 + a2 * g1) + n * n * c12
           + _cubic(n, s00, s11, s12, s22, a1, a2, S1, S2, kn[1, 1], kn[1, 2], kn[2, 1], kn[2, 2]))
    # local tangent J^T h J + q0 d2(bow)/d(theta)2, J = I + e0 (0, b1, b2) (Kn couples the
    # stretch to the end rotations where a hinge's centroid leaves its axis)
    ka = h00
    k01, k02 = h01 + ka * b1, h02 + ka * b2
    k11 = h11 + (2 * h01 + ka * b1) * b1 + 2 * p11 * q0
    k22 = h22 + (2 * h02 + ka * b2) * b2 + 2 * p22 * q0
    k12 = h12 + ka * b1 * b2 + h02 * b1 + h01 * b2 + p12 * q0
    # r = d(stretch)/dx, z = Ln d(chord angle)/dx in node dofs (xa, ya, ta, xb, yb, tb)
    r[0], r[1], r[2], r[3], r[4], r[5] = -c, -s, 0.0, c, s, 0.0
    z[0], z[1], z[2], z[3], z[4], z[5] = s, -c, 0.0, -s, c, 0.0
    inv = -1.0 / Ln
    for j in range(6):
        Bm[0, j] = r[j]
        Bm[1, j] = z[j] * inv
        Bm[2, j] = z[j] * inv
    Bm[1, 2] += 1.0
    Bm[2, 5] += 1.0
    for j in range(6):
        KB[0, j] = ka * Bm[0, j] + k01 * Bm[1, j] + k02 * Bm[2, j]
        KB[1, j] = k01 * Bm[0, j] + k11 * Bm[1, j] + k12 * Bm[2, j]
        KB[2, j] = k02 * Bm[0, j] + k12 * Bm[1, j] + k22 * Bm[2, j]
        f[j] = Bm[0, j] * qf[0] + Bm[1, j] * qf[1] + Bm[2, j] * qf[2]
    gz = qf[0] / Ln
    gr = (qf[1] + qf[2]) / (Ln * Ln)
    for i in range(6):
        for j in range(6):
            K[i, j] = (Bm[0, i] * KB[0, j] + Bm[1, i] * KB[1, j] + Bm[2, i] * KB[2, j]
                       + gz * z[i] * z[j] + gr * (r[i] * z[j] + z[i] * r[j]))
    # node dofs -> body dofs: x_node = x_master + rho, d x_node / d theta_body = perp(rho);
    # K_body = T^T K T plus the turning of rho under the node force
    for col in (2, 5):
        base = col - 2
        px, py = -rho[a if col == 2 else b, 1], rho[a if col == 2 else b, 0]
        for i in range(6):
            K[i, col] += K[i, base] * px + K[i, base + 1] * py
        for j in range(6):
            K[col, j] += K[base, j] * px + K[base + 1, j] * py
        f[col] += f[base] * px + f[base + 1] * py
    K[2, 2] -= rho[a, 0] * f[0] + rho[a, 1] * f[1]
    K[5, 5] -= rho[b, 0] * f[3] + rho[b, 1] * f[4]
    return energy


@njit(cache=True, error_model="numpy")
def _port(node, direction, body_of_node, dof_of_body, u, rho, g):
    """Travel of a node along a direction, and its gradient g on the reduced dofs."""
    dofs = dof_of_body[body_of_node[node]]
    for i in range(g.shape[0]):
        g[i] = 0.0
    gx, gy = direction[0], direction[1]
    gt = -rho[node, 1] * direction[0] + rho[node, 0] * direction[1]
    if dofs[0] >= 0:
        g[dofs[0]] = gx
    if dofs[1] >= 0:
        g[dofs[1]] = gy
    if dofs[2] >= 0:
        g[dofs[2]] = gt
    return u[node, 0] * direction[0] + u[node, 1] * direction[1]


@njit(cache=True, error_model="numpy")
def _evaluate(q, lam, topo, bt, b, w):
    """Residual w.F (out-of-balance forces, F - lam g_in), tangent w.Kg, the input port's
    gradient w.g_in and the output port's gradient w.g_out at state q; returns the output travel."""
    body_of_node, dof_of_body, ea, eb, elem_dofs, in_node, out_node = topo[:7]
    # design b's constants and the scratch arrays taken once (not at every member's call)
    r0, d0, L0, beta0, Kn, f_in, d_out, Bw = (bt[0][b], bt[1][b], bt[2][b], bt[3][b], bt[4][b],
                                              bt[5][b], bt[6][b], bt[7][b])
    u, th, rho, defo, qf, f, Ke, Bm, KB, z, r = w.u, w.th, w.rho, w.defo, w.qf, w.f, w.Ke, w.Bm, w.KB, w.z, w.r
    F, Kg = w.F, w.Kg
    node_state(q, body_of_node, r0, u, th, rho)
    nd = F.shape[0]
    row_start, row_end = topo[7], topo[8]
    for i in range(nd):
        F[i] = 0.0
        for j in range(row_start[i], row_end[i] + 1):     # Kg is zero outside the envelope
            Kg[i, j] = 0.0
    for k in range(ea.shape[0]):
        element(k, ea, eb, d0, L0, beta0, Kn, Bw, u, th, rho, defo, qf, f, Ke, Bm, KB, z, r)
        for i in range(6):
            di = elem_dofs[k, i]
            if di < 0:
                continue
            F[di] += f[i]
            for j in range(6):
                dj = elem_dofs[k, j]
                if dj >= 0:
                    Kg[di, dj] += Ke[i, j]
    _port(in_node, f_in, body_of_node, dof_of_body, u, rho, w.g_in)
    travel = _port(out_node, d_out, body_of_node, dof_of_body, u, rho, w.g_out)
    # dead load lam f_in at the input node: its moment arm turns with the body
    for i in range(nd):
        F[i] -= lam * w.g_in[i]
    rot = dof_of_body[body_of_node[in_node], 2]
    if rot >= 0:
        Kg[rot, rot] += lam * (rho[in_node, 0] * f_in[0] + rho[in_node, 1] * f_in[1])
    return travel


@njit(cache=True, error_model="numpy")
def solve_in_place(W, m, ncore, row_end, reach):
    """Solve the m x m system W[:m, :m] x = W[:m, m] by Gaussian elimination with partial
    pivoting; x replaces W[:m, m]. Rows and columns below ``ncore`` are banded: row i's
    nonzeros end at column row_end[i] and column k's at row reach[k] (nondecreasing); the
    kernel skips the zeros outside, tracking the fill-in of the row exchanges. Rows and
    columns from ncore to m - 1 are dense. Returns False if a pivot is exactly zero
    (singular) or the solution is not finite."""
    hi = np.empty(m, dtype=np.int64)
    for i in range(m):
        if i < ncore:
            hi[i] = row_end[i]
        else:
            last = -1
            for j in range(ncore):
                if W[i, j] != 0.0:
                    last = j
            hi[i] = last
    for k in range(m):
        # the rows below k that can hold column k: core rows up to the last that can reach
        # it, then the dense rows (the core rows in between hold zeros there)
        last = reach[k] if k < ncore else m - 1
        rows = ((k + 1, last + 1), (max(last + 1, ncore), m))
        p, big = k, abs(W[k, k])
        for start, stop in rows:
            for i in range(start, stop):
                v = abs(W[i, k])
                if v > big:
                    p, big = i, v
        if big == 0.0:
            return False
        if p != k:
            for j in range(k, m + 1):
                W[k, j], W[p, j] = W[p, j], W[k, j]
            hi[k], hi[p] = hi[p], hi[k]
        pivot = W[k, k]
        end = hi[k]
        for start, stop in rows:
            for i in range(start, stop):
                if W[i, k] == 0.0:
                    continue
                lik = W[i, k] / pivot
                W[i, k] = 0.0
                for j in range(k + 1, end + 1):
                    W[i, j] -= lik * W[k, j]
                for j in range(max(ncore, k + 1), m + 1):
                    W[i, j] -= lik * W[k, j]
                hi[i] = max(hi[i], end)
    for i in range(m - 1, -1, -1):
        s = W[i, m]
        for j in range(i + 1, hi[i] + 1):
            s -= W[i, j] * W[j, m]
        for j in range(max(ncore, i + 1), m):
            s -= W[i, j] * W[j, m]
        x = s / W[i, i]
        if not math.isfinite(x):
            return False
        W[i, m] = x
    return True


@njit(cache=True, error_model="numpy")
def positive_definite(K, L, row_start, reach):
    """Whether the symmetric part of K (n, n) is positive definite: Cholesky into L within
    the envelope (row i's nonzeros start at column row_start[i]; no row below reach[j]
    reaches back to column j)."""
    n = K.shape[0]
    for j in range(n):
        d = K[j, j]
        for k in range(row_start[j], j):
            d -= L[j, k] * L[j, k]
        if not d > 0.0:
            return False
        L[j, j] = math.sqrt(d)
        for i in range(j + 1, reach[j] + 1):
            if row_start[i] > j:
                continue
            s = 0.5 * (K[i, j] + K[j, i])
            for k in range(max(row_start[i], row_start[j]), j):
                s -= L[i, k] * L[j, k]
            L[i, j] = s / L[j, j]
    return True


@njit(cache=True, error_model="numpy")
def _apply(q, x, dof_of_body):
    for c in range(dof_of_body.shape[0]):
        for k in range(3):
            d = dof_of_body[c, k]
            if d >= 0:
                q[c, k] += x[d]


@njit(cache=True, error_model="numpy")
def _norm(v, weight):
    s = 0.0
    for i in range(v.shape[0]):
        s += (v[i] * weight[i]) ** 2
    return math.sqrt(s)


@njit(cache=True, error_model="numpy")
def _newton(q, lam, goal, target, lam_scale, verify, disp, tol, max_iterations, topo, bt, b, weight, w):
    """Equilibrium iterations of one design at one increment (see solver._Run.newton).
    Returns (status, lam, residual); q is updated in place and w.Kg holds the last tangent."""
    nd = w.F.shape[0]
    m = nd + 1 if disp else nd
    res = prev = np.inf
    stall = math.sqrt(tol)
    for _ in range(max_iterations):
        if not disp:
            lam = goal
        u_out = _evaluate(q, lam, topo, bt, b, w)
        if disp:
            scale = max(abs(lam), lam_scale * 1e-3) * _norm(w.g_in, weight)
            c = u_out - goal
            res = max(_norm(w.F, weight) / scale, abs(c) / max(target, 1e-12))
        else:
            res = _norm(w.F, weight) / (goal * _norm(w.g_in, weight))
        # converged, or stalled at round-off (no halving below sqrt(tol))
        if res < tol or (res < stall and res > 0.5 * prev):
            return CONVERGED, lam, res
        prev = res
        W = w.W
        for i in range(nd):
            for j in range(nd):
                W[i, j] = w.Kg[i, j]
            W[i, m] = -w.F[i]
        if disp:
            for i in range(nd):
                W[i, nd] = -w.g_in[i]
                W[nd, i] = w.g_out[i]
            W[nd, nd] = 0.0
            W[nd, m] = -c
        if not solve_in_place(W, m, nd, topo[8], topo[9]):
            return SINGULAR, lam, res
        for i in range(nd):
            w.x[i] = W[i, m]
        _apply(q, w.x, topo[1])
        if disp:
            lam = lam + W[nd, m]
        if not verify and res < EARLY_ACCEPT:
            return CONVERGED, lam, res
    return (CONVERGED if res < stall else NOT_CONVERGED), lam, res


@njit(cache=True, error_model="numpy")
def increment(q, lam, goal, target, lam_scale, alive, verify, disp, tol, max_iterations, topo, bt,
              weight, d_in, w, status, res, stable, u_in, u_out):
    """Newton at one increment for every alive design of a batch, each on its own: q (B, c, 3)
    and lam (B,) are updated in place; per design the status, the residual, whether the last
    tangent is positive definite, and both ports' travel at the new state."""
    body_of_node, in_node, out_node = topo[0], topo[5], topo[6]
    d_out = bt[6]
    for b in range(q.shape[0]):
        if not alive[b]:
            status[b] = CONVERGED
            continue
        status[b], lam[b], res[b] = _newton(q[b], lam[b], goal, target, lam_scale[b], verify, disp,
                                            tol, max_iterations, topo, bt, b, weight[b], w)
        stable[b] = status[b] == CONVERGED and positive_definite(w.Kg, w.L, topo[7], topo[9])
        node_state(q[b], body_of_node, bt[0][b], w.u, w.th, w.rho)
        u_in[b] = w.u[in_node, 0] * d_in[b, 0] + w.u[in_node, 1] * d_in[b, 1]
        u_out[b] = w.u[out_node, 0] * d_out[b, 0] + w.u[out_node, 1] * d_out[b, 1]


@njit(cache=True, error_model="numpy")
def final_state(q, topo, bt, w, u, th, defo, qf, energy):
    """Node displacements u (B, n, 2) and rotations th (B, n), member deformations defo and
    forces qf (B, e, 3) and strain energies (B, e) at the states q (B, c, 3)."""
    body_of_node, ea, eb = topo[0], topo[2], topo[3]
    r0, d0, L0, beta0, Kn, Bw = bt[0], bt[1], bt[2], bt[3], bt[4], bt[7]
    for b in range(q.shape[0]):
        node_state(q[b], body_of_node, r0[b], u[b], th[b], w.rho)
        for k in range(ea.shape[0]):
            energy[b, k] = element(k, ea, eb, d0[b], L0[b], beta0[b], Kn[b], Bw[b], u[b], th[b], w.rho,
                                   defo[b, k], qf[b, k], w.f, w.Ke, w.Bm, w.KB, w.z, w.r)
