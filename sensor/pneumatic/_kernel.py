"""Compiled physics of the pneumatic plant: continuous right-hand side and fixed-rate stepper.

The state vector is [z, v, side 1 block, side 2 block]; a side block holds the node
pressures P_k (Pa, the last node is the chamber), the element mass flows m_k (kg/s), the
unsteady-friction states y_{k,i} (kg/s) and the heat-transfer states w_{k,i} (Pa) of the tube
nodes.  Indices of the packed parameter vectors are the module constants below; the Python
side (:mod:`sensor.pneumatic.plant`) builds them.

Stepper (one substep h, command held): (1) piston, linearly implicit in (z, v); (2) element
flows, implicit in the steady friction and exponentially exact in the friction relaxations
(for a flow varying linearly over the substep); (3) node pressures from the new flows with
the valve flow linearised implicitly in the port pressure, the heat-transfer relaxations
integrated the same way, and mass (P V for the isothermal chamber) conserved exactly.  The
acoustic part is symplectic Euler, stable for h omega_max < 2 (checked by the plant).
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit

from sensor.pneumatic.valve import orifice_flow, port_flow

# common parameters pc[...]
RT, MU, GAMMA, PR, PATM, PSUP, BCRIT, RLAM, KREF = 0, 1, 2, 3, 4, 5, 6, 7, 8
A1, A2, AROD, STROKE, VD1, VD2, MASS, VISC, FC, VS = 9, 10, 11, 12, 13, 14, 15, 16, 17, 18
KLEAK, KSTOP, CSTOP, RPOLY, FIXED = 19, 20, 21, 22, 23
ENV_ATTACHED, ENV_K, ENV_B, ENV_M, ENV_Z0 = 24, 25, 26, 27, 28
N_COMMON = 29
# side parameters ps[s, ...]
S_NN, S_INERT, S_BORE, S_LAW, S_UNSTEADY, S_THERMAL, S_DELAY, S_ATTEN, S_LEN = 0, 1, 2, 3, 4, 5, 6, 7, 8
N_SIDE = 9
NU_TOL = 0.01   # relative viscosity change that triggers new relaxation factors
# fast-math flags without no-NaN / no-Inf, so the runaway check still sees NaN and Inf
FAST = {"nsz", "arcp", "contract", "afn", "reassoc"}
# offsets off[s, ...]
O_P, O_M, O_Y, O_W = 0, 1, 2, 3


@njit(cache=True)
def steady_coefficient(mdot, nu, bore, law, mu):
    """Steady friction coefficient f (1/s) on the mass flow (eq 54's f)."""
    re = 4.0 * abs(mdot) / (math.pi * bore * mu)
    lam = 32.0 * nu / (bore * bore)
    if law == 0:
        return lam + 0.158 * re**0.75 * nu / (bore * bore)
    if re <= 2300.0:
        return lam
    if re >= 4000.0:
        return 0.158 * re**0.75 * nu / (bore * bore)
    t4000 = 0.158 * 4000.0**0.75 * nu / (bore * bore)
    return lam + (t4000 - lam) * (re - 2300.0) / 1700.0


@njit(cache=True)
def rh_attenuation(mdot, pressure, pc, ps_s):
    """Richer-Hurmuzlu attenuation factor exp(-R_t R T L / (2 P c)) (eqs 4-5)."""
    bore = ps_s[S_BORE]
    re = 4.0 * abs(mdot) / (math.pi * bore * pc[MU])
    coef = 32.0 if re <= 2300.0 else 0.158 * re**0.75
    rt = coef * pc[MU] / (bore * bore)
    c = math.sqrt(pc[GAMMA] * pc[RT])
    return math.exp(-rt * pc[RT] * ps_s[S_LEN] / (2.0 * max(pressure, 1.0) * c))


@njit(cache=True)
def chamber_volumes(z, v, pc):
    """(V1, V2, dV1/dt, dV2/dt) of the actuator chambers (fixed chambers when pc[FIXED])."""
    if pc[FIXED] > 0.5:
        return pc[VD1], pc[VD2], 0.0, 0.0
    return pc[VD1] + pc[A1] * z, pc[VD2] + pc[A2] * (pc[STROKE] - z), pc[A1] * v, -pc[A2] * v


@njit(cache=True)
def piston_forces(z, v, p1, p2, pc):
    """(net force without inertia, d/dz, d/dv, spring-damper part of F_e) on the piston (N)."""
    fp = p1 * pc[A1] - p2 * pc[A2] - pc[PATM] * pc[AROD]
    th = math.tanh(v / pc[VS])
    f = fp - pc[VISC] * v - pc[FC] * th
    fz = 0.0
    fv = -pc[VISC] - pc[FC] * (1.0 - th * th) / pc[VS]
    fe = 0.0
    if pc[ENV_ATTACHED] > 0.5:
        fe = pc[ENV_K] * (z - pc[ENV_Z0]) + pc[ENV_B] * v
        f -= fe
        fz -= pc[ENV_K]
        fv -= pc[ENV_B]
    elif z > pc[ENV_Z0] and (pc[ENV_K] > 0.0 or pc[ENV_B] > 0.0):
        fe = pc[ENV_K] * (z - pc[ENV_Z0]) + pc[ENV_B] * v
        if fe > 0.0:
            f -= fe
            fz -= pc[ENV_K]
            fv -= pc[ENV_B]
        else:
            fe = 0.0
    if z < 0.0:
        f += -pc[KSTOP] * z - pc[CSTOP] * v
        fz -= pc[KSTOP]
        fv -= pc[CSTOP]
    elif z > pc[STROKE]:
        f += -pc[KSTOP] * (z - pc[STROKE]) - pc[CSTOP] * v
        fz -= pc[KSTOP]
        fv -= pc[CSTOP]
    return f, fz, fv, fe


@njit(cache=True)
def rhs(x, u, pc, ps, pv, off, kn, km, ka, grid, csup, cexh, hold0):
    """Continuous time derivative of the plant state (no transport delay).

    hold0: keep the first node of each side at its value (pressure imposed, for the
    linearised frequency response of a line)."""
    dx = np.zeros_like(x)
    rt, mu, gam = pc[RT], pc[MU], pc[GAMMA]
    kappa = (gam - 1.0) / gam
    kk = kn.size
    z, v = x[0], x[1]
    vol1, vol2, dv1, dv2 = chamber_volumes(z, v, pc)
    pch = np.empty(2)
    for s in range(2):
        pch[s] = x[off[s, O_P] + int(ps[s, S_NN]) - 1]
    if pc[FIXED] < 0.5:
        f, _, _, _ = piston_forces(z, v, pch[0], pch[1], pc)
        dx[0] = v
        dx[1] = f / (pc[MASS] + (pc[ENV_M] if pc[ENV_ATTACHED] > 0.5 else 0.0))
    leak = pc[KLEAK] * (pch[0] - pch[1]) if pc[FIXED] < 0.5 else 0.0
    for s in range(2):
        nn = int(ps[s, S_NN])
        op, om, oy, ow = off[s, O_P], off[s, O_M], off[s, O_Y], off[s, O_W]
        bore = ps[s, S_BORE]
        uns = ps[s, S_UNSTEADY] > 0.5
        the = ps[s, S_THERMAL] > 0.5
        for j in range(nn - 1):
            pa, pb, m = x[op + j], x[op + j + 1], x[om + j]
            nu = mu * 2.0 * rt / (pa + pb)
            fric = steady_coefficient(m, nu, bore, ps[s, S_LAW], mu) * m
            if uns:
                c16 = 16.0 * nu / (bore * bore)
                for i in range(kk):
                    fric += c16 * km[i] * x[oy + j * kk + i]
            dm = ps[s, S_INERT] * (pa - pb) - fric
            dx[om + j] = dm
            if uns:
                for i in range(kk):
                    beta = 4.0 * nu * kn[i] / (bore * bore)
                    dx[oy + j * kk + i] = dm - beta * x[oy + j * kk + i]
        sgn = 1.0 if s == 0 else -1.0
        mv, _ = port_flow(sgn * u, grid, csup, cexh, pc[BCRIT], pc[RLAM], pc[PSUP], x[op], pc[PATM], pc[KREF])
        for k in range(nn):
            flow = 0.0
            if k > 0:
                flow += x[om + k - 1]
            if k < nn - 1:
                flow -= x[om + k]
            if k == 0:
                if ps[s, S_ATTEN] > 0.5:
                    flow += mv * rh_attenuation(mv, x[op], pc, ps[s])
                else:
                    flow += mv
            p = x[op + k]
            if k == nn - 1:
                flow += -leak if s == 0 else leak
                vch = vol1 if s == 0 else vol2
                dvch = dv1 if s == 0 else dv2
                vol = pv[s, k] + vch
                r = pc[RPOLY]
                dp = r * (rt * flow - p * dvch) / vol
            elif the:
                nu = mu * rt / p
                sumw = 0.0
                for i in range(kk):
                    sumw += ka[i] * (4.0 * nu * kn[i] / (pc[PR] * bore * bore)) * x[ow + k * kk + i]
                dp = gam * (rt * flow / pv[s, k] - kappa * sumw)
            else:
                dp = rt * flow / pv[s, k]
            if k == 0 and hold0:
                dp = 0.0
            dx[op + k] = dp
            if the and k < nn - 1:
                nu = mu * rt / p
                for i in range(kk):
                    b = 4.0 * nu * kn[i] / (pc[PR] * bore * bore)
                    dx[ow + k * kk + i] = dp - b * x[ow + k * kk + i]
    return dx


@njit(cache=True, fastmath=FAST)
def advance(x, u, nsub, h, pc, ps, pv, off, kn, km, ka, grid, csup, cexh, ring, head, acc, vmax, work):
    """Advance the state x in place by nsub substeps of h seconds at valve command u.

    ring[s, :] holds past valve flows of a Richer-Hurmuzlu side (delay ps[s, S_DELAY] substeps,
    head the current ring index, returned updated).  acc[s] accumulates the valve mass (kg)
    delivered into side s, acc[2 + s] the mass delivered into its chamber; acc[4] is the
    environment force F_e (N) at the end of the step.  work: scratch of shape
    (2, nodes, 4 K + 5), zero on the first call (see :func:`work_array`).  Returns (head, index of the first
    non-finite or runaway state or -1, see :func:`first_bad`)."""
    rt, mu, gam = pc[RT], pc[MU], pc[GAMMA]
    kappa = (gam - 1.0) / gam
    kk = kn.size
    nring = ring.shape[1]
    mass_eff = pc[MASS] + (pc[ENV_M] if pc[ENV_ATTACHED] > 0.5 else 0.0)
    # relaxation factors e = exp(-beta h) and phi = (1 - e) / (beta h) of each element (friction)
    # and tube node (heat transfer), kept in work[s, j] and recomputed only when the local
    # kinematic viscosity has moved by more than NU_TOL since they were computed
    ef = work[:, :, 0:kk]
    pf = work[:, :, kk:2 * kk]
    et = work[:, :, 2 * kk:3 * kk]
    pt = work[:, :, 3 * kk:4 * kk]
    c16 = work[:, :, 4 * kk]
    for s in range(2):
        op = off[s, O_P]
        d2 = ps[s, S_BORE] * ps[s, S_BORE]
        for j in range(int(ps[s, S_NN]) - 1):
            nu = mu * 2.0 * rt / (x[op + j] + x[op + j + 1])
            if abs(nu - work[s, j, 4 * kk + 1]) > NU_TOL * nu or work[s, j, 4 * kk + 3] != h:
                work[s, j, 4 * kk + 1] = nu
                work[s, j, 4 * kk + 3] = h
                c16[s, j] = 16.0 * nu / d2
                for i in range(kk):
                    bh = 4.0 * nu * kn[i] / d2 * h
                    ef[s, j, i] = math.exp(-bh)
                    pf[s, j, i] = -math.expm1(-bh) / bh
            nu = mu * rt / x[op + j]
            if abs(nu - work[s, j, 4 * kk + 2]) > NU_TOL * nu or work[s, j, 4 * kk + 4] != h:
                work[s, j, 4 * kk + 2] = nu
                work[s, j, 4 * kk + 4] = h
                for i in range(kk):
                    bh = 4.0 * nu * kn[i] / (pc[PR] * d2) * h
                    et[s, j, i] = math.exp(-bh)
                    pt[s, j, i] = -math.expm1(-bh) / bh
    cond = np.empty((2, 2))   # (side, supply / exhaust) conductance at this command
    for s in range(2):
        us = u if s == 0 else -u
        cond[s, 0] = np.interp(us, grid, csup)
        cond[s, 1] = np.interp(us, grid, cexh)
    for _ in range(nsub):
        z, v = x[0], x[1]
        vol1, vol2, _, _ = chamber_volumes(z, v, pc)
        p_c1 = x[off[0, O_P] + int(ps[0, S_NN]) - 1]
        p_c2 = x[off[1, O_P] + int(ps[1, S_NN]) - 1]
        # (1) piston
        if pc[FIXED] < 0.5:
            f, fz, fv, _ = piston_forces(z, v, p_c1, p_c2, pc)
            vn = (v + h / mass_eff * (f - fv * v)) / (1.0 - h / mass_eff * (fz * h + fv))
            x[1] = vn
            x[0] = z + h * vn
            _, _, _, fe = piston_forces(x[0], vn, p_c1, p_c2, pc)
            acc[4] = fe + (pc[ENV_M] * (vn - v) / h if pc[ENV_ATTACHED] > 0.5 else 0.0)
        nvol1, nvol2, _, _ = chamber_volumes(x[0], x[1], pc)
        leak = pc[KLEAK] * (p_c1 - p_c2) if pc[FIXED] < 0.5 else 0.0
        head = (head + 1) % nring
        for s in range(2):
            nn = int(ps[s, S_NN])
            op, om, oy, ow = off[s, O_P], off[s, O_M], off[s, O_Y], off[s, O_W]
            bore = ps[s, S_BORE]
            d2 = bore * bore
            uns = ps[s, S_UNSTEADY] > 0.5
            the = ps[s, S_THERMAL] > 0.5
            # (2) element flows
            for j in range(nn - 1):
                pa, pb, m = x[op + j], x[op + j + 1], x[om + j]
                fs = steady_coefficient(m, mu * 2.0 * rt / (pa + pb), bore, ps[s, S_LAW], mu)
                drive = ps[s, S_INERT] * (pa - pb)
                extra = 0.0
                if uns:
                    c = c16[s, j]
                    for i in range(kk):
                        extra += h * c * km[i] * pf[s, j, i]
                        drive -= c * km[i] * x[oy + j * kk + i] * ef[s, j, i]
                mn = (m * (1.0 + extra) + h * drive) / (1.0 + h * fs + extra)
                x[om + j] = mn
                if uns:
                    for i in range(kk):
                        x[oy + j * kk + i] = x[oy + j * kk + i] * ef[s, j, i] + (mn - m) * pf[s, j, i]
            # (3) nodes
            m_in, _, din = orifice_flow(cond[s, 0], pc[BCRIT], pc[RLAM], pc[PSUP], x[op], pc[KREF])
            m_out, dout, _ = orifice_flow(cond[s, 1], pc[BCRIT], pc[RLAM], x[op], pc[PATM], pc[KREF])
            mv, dmv = m_in - m_out, din - dout
            delayed = ps[s, S_ATTEN] > 0.5
            if delayed:
                ring[s, head] = mv
                md = ring[s, (head - int(ps[s, S_DELAY])) % nring]
                into_chamber = md * rh_attenuation(md, x[op], pc, ps[s])
                acc[s] += h * mv
            for k in range(nn):
                flow = 0.0
                if k > 0:
                    flow += x[om + k - 1]
                if k < nn - 1:
                    flow -= x[om + k]
                g = 0.0
                if k == 0:
                    if delayed:
                        flow += into_chamber
                    else:
                        flow += mv
                        g = dmv
                p = x[op + k]
                if k == nn - 1:
                    flow += -leak if s == 0 else leak
                    vo = pv[s, k] + (vol1 if s == 0 else vol2)
                    vn_ = pv[s, k] + (nvol1 if s == 0 else nvol2)
                    r = pc[RPOLY]
                    if r == 1.0:
                        pn = (p * vo + h * rt * (flow - g * p)) / (vn_ - h * rt * g)
                    else:
                        fac = h * r * rt * vn_ ** (r - 1.0)
                        pn = (p * vo**r + fac * (flow - g * p)) / (vn_**r - fac * g)
                    if k == 0:
                        acc[s] += h * (mv + g * (pn - p)) if not delayed else 0.0
                    acc[2 + s] += h * (flow + g * (pn - p) + (leak if s == 0 else -leak))
                else:
                    cap = pv[s, k] / rt
                    rhs_ = h * flow
                    if the:
                        sa = 0.0
                        for i in range(kk):
                            sa += ka[i] * pt[s, k, i]
                            rhs_ += cap * kappa * ka[i] * x[ow + k * kk + i] * (et[s, k, i] - 1.0)
                        dp = rhs_ / (cap * (1.0 - kappa * sa) - h * g)
                        for i in range(kk):
                            x[ow + k * kk + i] = x[ow + k * kk + i] * et[s, k, i] + dp * pt[s, k, i]
                    else:
                        dp = rhs_ / (cap - h * g)
                    pn = p + dp
                    if k == 0:
                        acc[s] += h * (mv + g * dp)
                x[op + k] = pn
    return head, first_bad(x, off, ps, vmax)


@njit(cache=True)
def first_bad(x, off, ps, vmax):
    """Index of the first non-finite or runaway state (-1 if none): pressures must stay in
    (0, 1e8) Pa and |v| below vmax."""
    for i in range(x.size):
        if not math.isfinite(x[i]):
            return i
    if abs(x[1]) > vmax:
        return 1
    for s in range(2):
        for k in range(int(ps[s, S_NN])):
            p = x[off[s, O_P] + k]
            if p <= 0.0 or p > 1e8:
                return off[s, O_P] + k
    return -1


def work_array(pv, kn):
    """Zeroed scratch array for :func:`advance`."""
    return np.zeros((2, pv.shape[1], 4 * kn.size + 5))
