"""Compiled physics of the pneumatic plant: continuous right-hand side and fixed-rate stepper.

The state vector is [z, v, side 1 block, side 2 block]; a side block holds the node
pressures P_k (Pa, the last node is the chamber), the element mass flows m_k (kg/s), the
unsteady-friction states y_{k,i} (kg/s) and the heat-transfer states w_{k,i} (Pa) of the tube
nodes, at the offsets its SIDE record names; then the chamber-node masses and the spool.
Parameters, accumulators, the loop's log and the sensors are named records (numba structured
types :data:`COMMON`, :data:`SIDE`, :data:`ACC`, :data:`LOG`, :data:`SENSOR`, :data:`FILTER`,
:data:`LOOP`, defined together below; :mod:`sensor.pneumatic.plant` and
:mod:`sensor.pneumatic.simulate` fill them).  Only the stepper's scratch ``work`` keeps
offsets (see :func:`advance`).

Stepper (one substep h, command held): (1) piston, staggered like the line (velocity kicked
by the old forces with Newmark averaging of stiffness and damping, see :func:`piston_step`); (2) element
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

MAX_PRESSURE_PA = 1e8   # pressures beyond 1000 bar leave the models' range (runaway check)
N_POLES = 8   # kernel poles per element (unsteady friction, heat transfer); fixed here, in this file,
              # so that changing it recompiles the cached stepper
STOP_RESOLUTION = 0.15   # piston substep times the end stop's natural frequency while at a stop
SPOOL_DAMPING = 1.0 / math.sqrt(2.0)   # second-order spool: -3 dB at the natural frequency
# extra states after both side blocks: x[pc.ox + s] chamber-node gas mass of side s (kg),
# x[pc.ox + 2] spool position (normalised command), x[pc.ox + 3] its rate (1/s)
X_SPOOL, X_SPOOL_RATE = 2, 3
N_EXTRA = 4
LAW_RESISTIVE = 2   # friction law of the preliminary model (eqs 7-13): algebraic flow a (P_a - P_b)
NU_TOL = 0.01   # relative viscosity change that triggers new relaxation factors
# fast-math flags without no-NaN / no-Inf, so the runaway check still sees NaN and Inf
FAST = {"nsz", "arcp", "contract", "afn", "reassoc"}
F8, I8, B1 = np.float64, np.int64, np.bool_

# --- the named records of the kernel (numba structured types; every field in SI units) -------------
#: Common parameters of the plant: gas (R T, viscosity, gamma, Prandtl), pressures, valve (ISO 6358 b,
#: laminar ratio, k_ref), actuator (areas, stroke, dead volumes, mass, friction, leak, end stops,
#: polytropic r or the energy equation), environment, spool dynamics (order 0 ideal, 1 or 2; its
#: exact step matrix for the substep), the index of the first extra state and the line temperature.
COMMON = np.dtype([
    ("rt", F8), ("mu", F8), ("gamma", F8), ("prandtl", F8), ("p_atm", F8), ("p_supply", F8),
    ("b_crit", F8), ("r_lam", F8), ("k_ref", F8),
    ("area_1", F8), ("area_2", F8), ("area_rod", F8), ("stroke", F8), ("dead_1", F8), ("dead_2", F8),
    ("mass", F8), ("viscous", F8), ("coulomb", F8), ("coulomb_velocity", F8), ("leak", F8),
    ("stop_k", F8), ("stop_c", F8), ("polytropic", F8), ("fixed", B1),
    ("env_attached", B1), ("env_k", F8), ("env_b", F8), ("env_m", F8), ("env_z0", F8),
    ("stick", B1), ("static_friction", F8), ("stribeck_velocity", F8),
    ("energy", B1), ("wall_ha", F8, (2,)),
    ("spool_order", I8), ("spool_w", F8), ("spool_step", F8, (2, 2)),
    ("ox", I8), ("t_air", F8)])
#: One side's line: node count, inertance A/dx (m), bore, area, length, friction law, switches,
#: transport delay (substeps), Mach limit, and the offsets of its pressures, flows, friction and
#: heat-transfer states in the state vector.
SIDE = np.dtype([
    ("nn", I8), ("inertance", F8), ("bore", F8), ("area", F8), ("length", F8), ("law", I8),
    ("unsteady", B1), ("thermal", B1), ("attenuation", B1), ("convective", B1), ("delay", I8),
    ("mach_limit", F8), ("o_p", I8), ("o_m", I8), ("o_y", I8), ("o_w", I8)])
#: What one control period accumulates per side: valve and chamber mass (kg), largest element
#: Mach, largest exit-face Mach, choked, the element of the largest Mach; and the environment force (N).
ACC = np.dtype([("valve", F8, (2,)), ("chamber", F8, (2,)), ("mach", F8, (2,)), ("exit_mach", F8, (2,)),
                ("choked", I8, (2,)), ("element", I8, (2,)), ("force", F8)])   # numba: no bool subarrays
#: One row of the loop's record: the period's mean valve and chamber flows (kg/s), peak element and
#: exit-face Mach, choked (per side), the environment force (N), the command and the eight readings
#: (MEASUREMENT_KEYS order).
LOG = np.dtype([("valve", F8, (2,)), ("chamber", F8, (2,)), ("mach", F8, (2,)), ("exit_mach", F8, (2,)),
                ("choked", F8, (2,)), ("force", F8), ("command", F8), ("meas", F8, (8,))])
#: A compiled sensor (kind SENSOR_NOISY or SENSOR_ENCODER, noise, resolution or count; kind < 0:
#: the sensors are read in Python) and a differentiating filter (y <- a y + b (x - x_prev)).
SENSOR = np.dtype([("kind", F8), ("noise", F8), ("resolution", F8)])
FILTER = np.dtype([("a", F8), ("b", F8), ("x_prev", F8), ("y", F8)])
SENSOR_NOISY, SENSOR_ENCODER = 0.0, 1.0
#: Everything :func:`control_period` needs besides the state, the node volumes and the valve table:
#: substeps, their length, the control period, the runaway velocity, the Richer-Hurmuzlu ring head,
#: the state indices of the four sensed pressures, the plant's records and the kernel poles.
LOOP = np.dtype([("nsub", I8), ("h", F8), ("dt", F8), ("vmax", F8), ("head", I8), ("p_read", I8, (4,)),
                 ("pc", COMMON), ("ps", SIDE, (2,)), ("kn", F8, (N_POLES,)), ("km", F8, (N_POLES,)),
                 ("ka", F8, (N_POLES,))])


def record(dtype: np.dtype, n: int | None = None) -> np.ndarray:
    """A zeroed record (shape (1,)) or n records of ``dtype``.  The compiled entry points take
    them as byte views (:func:`as_bytes`) and read them back with ``.view(DTYPE)``: a plain byte
    array costs numba's dispatcher far less than a structured one."""
    return np.zeros(1 if n is None else n, dtype)


def as_bytes(records: np.ndarray) -> np.ndarray:
    """The bytes of ``records`` (a view: the kernel writes through it)."""
    return records.view(np.uint8)


@njit(cache=True)
def pow075(x):
    """x^0.75 for x >= 0 as sqrt(x sqrt(x)) (two square roots are much cheaper than pow)."""
    return math.sqrt(x * math.sqrt(x))


@njit(cache=True, fastmath=FAST)
def interp1(x, xp, fp):
    """np.interp(x, xp, fp) for a scalar x on a strictly increasing grid xp, without the array
    allocations of the general one; the same arithmetic (and fast-math flags, as np.interp had
    inside the stepper), so the same result."""
    n = xp.size
    if math.isnan(x):
        return x
    if x > xp[n - 1]:
        return fp[n - 1]
    if x < xp[0]:
        return fp[0]
    j = 0
    while j < n - 1 and x >= xp[j + 1]:
        j += 1
    if j == n - 1 or xp[j] == x:
        return fp[j]
    slope = (fp[j + 1] - fp[j]) / (xp[j + 1] - xp[j])
    y = slope * (x - xp[j]) + fp[j]
    if math.isnan(y):
        y = slope * (x - xp[j + 1]) + fp[j + 1]
        if math.isnan(y) and fp[j] == fp[j + 1]:
            y = fp[j]
    return y


@njit(cache=True)
def steady_coefficient(mdot, nu, bore, law, mu):
    """Steady friction coefficient f (1/s) on the mass flow (eq 54's f)."""
    re = 4.0 * abs(mdot) / (math.pi * bore * mu)
    lam = 32.0 * nu / (bore * bore)
    if law == 0:
        return lam + 0.158 * pow075(re) * nu / (bore * bore)
    if re <= 2300.0:
        return lam
    if re >= 4000.0:
        return 0.158 * pow075(re) * nu / (bore * bore)
    t4000 = 0.158 * 4000.0**0.75 * nu / (bore * bore)
    return lam + (t4000 - lam) * (re - 2300.0) / 1700.0


@njit(cache=True)
def rh_attenuation(mdot, pressure, pc, ps_s):
    """Richer-Hurmuzlu attenuation factor exp(-R_t R T L / (2 P c)) (eqs 4-5)."""
    bore = ps_s.bore
    re = 4.0 * abs(mdot) / (math.pi * bore * pc.mu)
    coef = 32.0 if re <= 2300.0 else 0.158 * pow075(re)
    rt = coef * pc.mu / (bore * bore)
    c = math.sqrt(pc.gamma * pc.rt)
    return math.exp(-rt * pc.rt * ps_s.length / (2.0 * max(pressure, 1.0) * c))


@njit(cache=True)
def resistive_conductance(valve_flow, p_port, pc, ps_s):
    """a = rho A / (L R_t) of eq 10 (kg/(s Pa)): rho from the valve-port pressure (eq 11), R_t of
    eq 5 at the Reynolds number of the valve flow at that pressure (the preliminary model)."""
    bore = ps_s.bore
    re = 4.0 * abs(valve_flow) / (math.pi * bore * pc.mu)
    coef = 32.0 if re <= 2300.0 else 0.158 * pow075(re)
    return (p_port / pc.rt) * ps_s.area / (ps_s.length * coef * pc.mu / (bore * bore))


@njit(cache=True)
def end_thrust(m, p, area, rt):
    """A P + m^2 R T / (A P) (N): pressure plus momentum flux through a tube end face, limited by
    isothermal choking - once the face velocity would exceed sqrt(R T) (Mach 1 / sqrt(gamma)) the
    gas leaves at the sonic pressure m sqrt(R T) / A above P and the thrust is 2 |m| sqrt(R T)."""
    c = math.sqrt(rt)
    if area * p >= abs(m) * c:
        return area * p + m * m * rt / (area * p)
    return 2.0 * abs(m) * c


@njit(cache=True)
def entrance_choked(sonic, p0, gam):
    """Whether a node at stagnation pressure p0 cannot feed a tube face at its isothermal sonic
    pressure ``sonic``: p0 <= sonic (1 + (gamma - 1) / (2 gamma))^(gamma / (gamma - 1)) (the
    isentropic relation of :func:`entrance_pressure` at M = 1 / sqrt(gamma))."""
    return p0 <= sonic * (1.0 + 0.5 * (gam - 1.0) / gam) ** (gam / (gam - 1.0))


@njit(cache=True)
def entrance_pressure(m, p0, area, rt, gam):
    """Static pressure (Pa) of the tube face a flow |m| (kg/s) enters from a node at stagnation
    pressure p0: isentropic, p0 = p (1 + (gamma - 1)/2 M^2)^(gamma/(gamma - 1)), with the face Mach
    M = |m| R T / (A p sqrt(gamma R T)) at the line temperature (the convention of an isothermal
    line; Shapiro 1953, ch. 4 and 6).  Newton from p0 (the residual is increasing and convex above
    the isothermal sonic pressure |m| sqrt(R T) / A); a flow the node cannot feed at that face
    (the entrance chokes) gets the sonic pressure."""
    g = abs(m) / area
    if g == 0.0:
        return p0
    a = 0.5 * (gam - 1.0) / gam * g * g * rt
    k = gam / (gam - 1.0)
    sonic = g * math.sqrt(rt)
    if entrance_choked(sonic, p0, gam):
        return sonic
    p = p0
    for _ in range(30):
        q = a / (p * p)
        base = 1.0 + q
        f = p * base**k - p0
        df = base ** (k - 1.0) * (1.0 - (2.0 * k - 1.0) * q)
        step = f / df
        p -= step
        if abs(step) <= 1e-12 * p0:
            break
    return max(p, sonic)


@njit(cache=True)
def face_pressure(m_out, p_node, area, rt, gam):
    """Static pressure (Pa) at a tube end face whose flow m_out (kg/s) leaves the node when > 0:
    the isentropic entrance from the node's stagnation state (:func:`entrance_pressure`); a flow
    into the node leaves the tube as a jet at the node pressure (the dump loss)."""
    if m_out > 0.0:
        return entrance_pressure(m_out, p_node, area, rt, gam)
    return p_node


@njit(cache=True)
def face_thrusts(x, op, om, nn, area, rt, gam, phi):
    """Thrust (A P + momentum flux, N) at every node face of a segmented tube into phi[:nn].

    Interior nodes carry the momentum of the upwind element at the mean node flow (donor cell);
    the two end faces carry their element's flow at the face pressure (:func:`face_pressure`,
    :func:`end_thrust`)."""
    m0, m1 = x[om], x[om + nn - 2]
    phi[0] = end_thrust(m0, face_pressure(m0, x[op], area, rt, gam), area, rt)
    phi[nn - 1] = end_thrust(m1, face_pressure(-m1, x[op + nn - 1], area, rt, gam), area, rt)
    for k in range(1, nn - 1):
        ma, mb = x[om + k - 1], x[om + k]
        mean = 0.5 * (ma + mb)
        up = ma if mean >= 0.0 else mb
        phi[k] = area * x[op + k] + mean * up * rt / (area * x[op + k])


@njit(cache=True)
def element_mach(m, pa, pb, first, last, area, rt, c2):
    """Mach number |m| R T / (A P c) of a flow element at the mean of its face pressures; a tube
    end face counts at no less than its choked pressure |m| sqrt(R T) / A (:func:`end_thrust`)."""
    sonic = abs(m) * math.sqrt(rt) / area
    if first:
        pa = max(pa, sonic)
    if last:
        pb = max(pb, sonic)
    return abs(m) * 2.0 * rt / (area * (pa + pb) * math.sqrt(c2))


@njit(cache=True)
def exit_face(m, sign, p_node, area, rt, c2, gam, acc, s):
    """Record the Mach number of a tube end face the flow leaves (sign m > 0: element flow m with
    sign +1 at the chamber end, -1 at the valve end) in acc.exit_mach[s], and a choked end (the jet
    at the isothermal sonic speed sqrt(R T), its pressure above the node's, or a choked entrance)
    in acc.choked[s]."""
    sonic = abs(m) * math.sqrt(rt) / area
    if sign * m > 0.0:
        acc.exit_mach[s] = max(acc.exit_mach[s], abs(m) * rt / (area * max(p_node, sonic) * math.sqrt(c2)))
        if sonic > p_node:
            acc.choked[s] = 1
    elif sign * m < 0.0 and entrance_choked(sonic, p_node, gam):
        acc.choked[s] = 1


@njit(cache=True)
def chamber_volumes(z, v, pc):
    """(V1, V2, dV1/dt, dV2/dt) of the actuator chambers (fixed chambers when pc.fixed)."""
    if pc.fixed:
        return pc.dead_1, pc.dead_2, 0.0, 0.0
    return pc.dead_1 + pc.area_1 * z, pc.dead_2 + pc.area_2 * (pc.stroke - z), pc.area_1 * v, -pc.area_2 * v


@njit(cache=True)
def sliding_friction(v, pc):
    """Dry friction magnitude (N) while sliding at v: Coulomb F_c, plus the Stribeck rise to the
    static friction F_s at low speed when stick-slip is on, F_c + (F_s - F_c) exp(-(v / v_st)^2)."""
    if pc.stick:
        return pc.coulomb + (pc.static_friction - pc.coulomb) * math.exp(-(v / pc.stribeck_velocity) ** 2)
    return pc.coulomb


@njit(cache=True)
def piston_forces(z, v, p1, p2, pc, dry=True):
    """(net force without inertia, d/dz, d/dv, spring-damper part of F_e) on the piston (N).

    dry: include the dry friction, smoothed as F(v) tanh(v / v_s) (eq 18's Coulomb term with the
    Stribeck curve of :func:`sliding_friction`); the stepper handles stick-slip itself (dry=False)."""
    fp = p1 * pc.area_1 - p2 * pc.area_2 - pc.p_atm * pc.area_rod
    f = fp - pc.viscous * v
    fz = 0.0
    fv = -pc.viscous
    if dry:
        th = math.tanh(v / pc.coulomb_velocity)
        fd = sliding_friction(v, pc)
        f -= fd * th
        fv -= fd * (1.0 - th * th) / pc.coulomb_velocity
    fe = 0.0
    if pc.env_attached:
        fe = pc.env_k * (z - pc.env_z0) + pc.env_b * v
        f -= fe
        fz -= pc.env_k
        fv -= pc.env_b
    elif z > pc.env_z0 and (pc.env_k > 0.0 or pc.env_b > 0.0):
        fe = pc.env_k * (z - pc.env_z0) + pc.env_b * v
        if fe > 0.0:
            f -= fe
            fz -= pc.env_k
            fv -= pc.env_b
        else:
            fe = 0.0
    if z < 0.0:
        f += -pc.stop_k * z - pc.stop_c * v
        fz -= pc.stop_k
        fv -= pc.stop_c
    elif z > pc.stroke:
        f += -pc.stop_k * (z - pc.stroke) - pc.stop_c * v
        fz -= pc.stop_k
        fv -= pc.stop_c
    return f, fz, fv, fe


@njit(cache=True)
def chamber_dp(p, mass, flow, vol, dvol, s, pc):
    """dP/dt of a chamber node: eq 15 with exponent r, or (pc.energy) the energy equation
    V dP/dt = gamma R T_in m_dot - gamma P dV/dt + (gamma - 1) h A (T_w - T), T = P V / (m R),
    where inflow enters at the line temperature and outflow leaves at the chamber's own T."""
    rt = pc.rt
    if pc.energy:
        gam = pc.gamma
        t_ch = p * vol / (mass * (rt / pc.t_air))
        rt_in = rt if flow >= 0.0 else rt * t_ch / pc.t_air
        ha = pc.wall_ha[s]
        return (gam * rt_in * flow - gam * p * dvol + (gam - 1.0) * ha * (pc.t_air - t_ch)) / vol
    r = pc.polytropic
    return r * (rt * flow - p * dvol) / vol


@njit(cache=True)
def rhs(x, u, pc, ps, pv, kn, km, ka, grid, csup, cexh, hold0):
    """Continuous time derivative of the plant state (no transport delay).

    hold0: keep the first node of each side at its value (pressure imposed, for the
    linearised frequency response of a line)."""
    dx = np.zeros_like(x)
    rt, mu, gam = pc.rt, pc.mu, pc.gamma
    kappa = (gam - 1.0) / gam
    kk = kn.size
    ox = pc.ox
    z, v = x[0], x[1]
    vol1, vol2, dv1, dv2 = chamber_volumes(z, v, pc)
    pch = np.empty(2)
    for s in range(2):
        pch[s] = x[ps[s].o_p + ps[s].nn - 1]
    if not pc.fixed:
        f, _, _, _ = piston_forces(z, v, pch[0], pch[1], pc)
        dx[0] = v
        dx[1] = f / (pc.mass + (pc.env_m if pc.env_attached else 0.0))
    leak = pc.leak * (pch[0] - pch[1]) if not pc.fixed else 0.0
    us = u
    if pc.spool_order > 0.5:
        us = x[ox + X_SPOOL]
        w = pc.spool_w
        if pc.spool_order < 1.5:
            dx[ox + X_SPOOL] = w * (u - us)
        else:
            dx[ox + X_SPOOL] = x[ox + X_SPOOL_RATE]
            dx[ox + X_SPOOL_RATE] = w * w * (u - us) - SPOOL_DAMPING * 2.0 * w * x[ox + X_SPOOL_RATE]
    phi = np.empty(max(ps[0].nn, ps[1].nn))
    for s in range(2):
        nn = ps[s].nn
        op, om, oy, ow = ps[s].o_p, ps[s].o_m, ps[s].o_y, ps[s].o_w
        bore = ps[s].bore
        uns = ps[s].unsteady
        the = ps[s].thermal
        sgn = 1.0 if s == 0 else -1.0
        mv, _ = port_flow(sgn * us, grid, csup, cexh, pc.b_crit, pc.r_lam, pc.p_supply, x[op], pc.p_atm, pc.k_ref)
        resistive = ps[s].law == LAW_RESISTIVE
        if ps[s].convective and nn > 1:
            face_thrusts(x, op, om, nn, ps[s].area, rt, gam, phi)
        flows = np.empty(max(nn - 1, 1))
        for j in range(nn - 1):
            pa, pb, m = x[op + j], x[op + j + 1], x[om + j]
            if resistive:
                flows[j] = resistive_conductance(mv, x[op], pc, ps[s]) * (pa - pb)
                continue
            flows[j] = m
            nu = mu * 2.0 * rt / (pa + pb)
            fric = steady_coefficient(m, nu, bore, ps[s].law, mu) * m
            if uns:
                c16 = 16.0 * nu / (bore * bore)
                for i in range(kk):
                    fric += c16 * km[i] * x[oy + j * kk + i]
            if ps[s].convective:
                dm = ps[s].inertance / ps[s].area * (phi[j] - phi[j + 1]) - fric
            else:
                dm = ps[s].inertance * (pa - pb) - fric
            dx[om + j] = dm
            if uns:
                for i in range(kk):
                    beta = 4.0 * nu * kn[i] / (bore * bore)
                    dx[oy + j * kk + i] = dm - beta * x[oy + j * kk + i]
        for k in range(nn):
            flow = 0.0
            if k > 0:
                flow += flows[k - 1]
            if k < nn - 1:
                flow -= flows[k]
            if k == 0:
                if ps[s].attenuation:
                    flow += mv * rh_attenuation(mv, x[op], pc, ps[s])
                else:
                    flow += mv
            p = x[op + k]
            if k == nn - 1:
                flow += -leak if s == 0 else leak
                vol = pv[s, k] + (vol1 if s == 0 else vol2)
                dp = chamber_dp(p, x[ox + s], flow, vol, dv1 if s == 0 else dv2, s, pc)
                dx[ox + s] = flow
            elif the:
                nu = mu * rt / p
                sumw = 0.0
                for i in range(kk):
                    sumw += ka[i] * (4.0 * nu * kn[i] / (pc.prandtl * bore * bore)) * x[ow + k * kk + i]
                dp = gam * (rt * flow / pv[s, k] - kappa * sumw)
            else:
                dp = rt * flow / pv[s, k]
            if k == 0 and hold0:
                dp = 0.0
            dx[op + k] = dp
            if the and k < nn - 1:
                nu = mu * rt / p
                for i in range(kk):
                    b = 4.0 * nu * kn[i] / (pc.prandtl * bore * bore)
                    dx[ow + k * kk + i] = dp - b * x[ow + k * kk + i]
    return dx


@njit(cache=True)
def spool_step(x, u, pc):
    """Advance the spool state by one substep (exact for the held command) and return the spool
    position; with ideal spool dynamics the position is the command itself."""
    ox = pc.ox
    order = pc.spool_order
    if order < 0.5:
        x[ox + X_SPOOL] = u
        return u
    y, r = x[ox + X_SPOOL] - u, x[ox + X_SPOOL_RATE]
    if order < 1.5:
        x[ox + X_SPOOL] = u + pc.spool_step[0, 0] * y
        return x[ox + X_SPOOL]
    x[ox + X_SPOOL] = u + pc.spool_step[0, 0] * y + pc.spool_step[0, 1] * r
    x[ox + X_SPOOL_RATE] = pc.spool_step[1, 0] * y + pc.spool_step[1, 1] * r
    return x[ox + X_SPOOL]


@njit(cache=True)
def piston_step(x, h, kick, p_c1, p_c2, pc, mass_eff):
    """One substep h of the piston (z, v), staggered like the line (leapfrog): the velocity is
    kicked over ``kick`` (h, or h / 2 for the first kick of a run, which starts the velocity half
    a substep ahead of the position) by the force at the old position and chamber pressures,
    with the damping at the mean of old and new velocity and the stiffness at the average
    position of Newmark's beta = 1/4 (unconditionally stable against the stiff end stops, second
    order); then z advances by h at the new velocity.  Karnopp stick-slip when pc.stick: at rest
    the piston stays stuck while the applied force is within the static friction F_s, and a
    sliding piston whose velocity would change sign in the step stops (sticks) instead."""
    z, v = x[0], x[1]
    if not pc.stick:
        f, fz, fv, _ = piston_forces(z, v, p_c1, p_c2, pc, True)
        vn = v + kick / mass_eff * f / (1.0 - kick / mass_eff * (0.25 * fz * h + 0.5 * fv))
    else:
        fa, fz, fv, _ = piston_forces(z, v, p_c1, p_c2, pc, False)
        if v == 0.0:
            if abs(fa) <= pc.static_friction:
                return
            d = 1.0 if fa > 0.0 else -1.0
        else:
            d = 1.0 if v > 0.0 else -1.0
        f = fa - d * sliding_friction(v, pc)
        vn = v + kick / mass_eff * f / (1.0 - kick / mass_eff * (0.25 * fz * h + 0.5 * fv))
        if vn * d < 0.0:
            vn = 0.0
    x[1] = vn
    x[0] = z + h * vn


@njit(cache=True, fastmath=FAST)
def advance(x, u, nsub, h, pc, ps, pv, kn, km, ka, grid, csup, cexh, ring, head, acc, vmax, work,
            start=False):
    """Advance the state x in place by nsub substeps of h seconds at valve command u.

    ring[s, :] holds past valve flows of a Richer-Hurmuzlu side (delay ps[s].delay substeps,
    head the current ring index, returned updated).  acc.valve[s] accumulates the valve mass
    (kg) delivered into side s, acc.chamber[s] the mass delivered into its chamber; acc.force
    is the environment force F_e (N) at the end of the step, acc.mach[s] the largest Mach
    number |m| R T / (A P c) of side s's flow elements during the step (acc.element[s] which),
    acc.exit_mach[s] and acc.choked[s] those of its end faces (:func:`exit_face`); acc is an ACC
    record, pc a COMMON record, ps the two SIDE records.  work: scratch of shape (2, nodes, 6 K + 7),
    zero on the first call (see :func:`work_array`).  start: this is the first step of a run (the
    piston's first kick is a half kick, see :func:`piston_step`).  Returns (head, index of the
    first non-finite or runaway state or -1, see :func:`first_bad`)."""
    rt, mu, gam = pc.rt, pc.mu, pc.gamma
    kappa = (gam - 1.0) / gam
    c2 = gam * rt
    kk = N_POLES   # kn.size, fixed at compile time so the loops over the poles unroll and vectorise
    ox = pc.ox
    nring = ring.shape[1]
    mass_eff = pc.mass + (pc.env_m if pc.env_attached else 0.0)
    # relaxation factors e = exp(-beta h) and phi = (1 - e) / (beta h) of each element (friction)
    # and tube node (heat transfer), and the sums the steps need, kept in work[s, j] and recomputed
    # only when the local kinematic viscosity has moved by more than NU_TOL since they were computed
    # (offsets into work[s, j] - indexing the one C-contiguous array, not strided views of it,
    # lets the compiler vectorise the relaxation loops)
    ef, pf, et, pt = 0, kk, 2 * kk, 3 * kk
    cf = 4 * kk                        # (16 nu / D^2) m_i e_i: weight of y_i in the friction drive
    ch = 5 * kk                        # kappa a_i (e_i - 1): weight of w_i in the node update
    w0 = 6 * kk                        # scalars: nu_f, nu_t, h_f, h_t, thrust, extra, sum a_i phi_i
    for s in range(2):
        op = ps[s].o_p
        d2 = ps[s].bore * ps[s].bore
        for j in range(ps[s].nn - 1):
            nu = mu * 2.0 * rt / (x[op + j] + x[op + j + 1])
            if abs(nu - work[s, j, w0]) > NU_TOL * nu or work[s, j, w0 + 2] != h:
                work[s, j, w0] = nu
                work[s, j, w0 + 2] = h
                c16 = 16.0 * nu / d2
                extra = 0.0
                for i in range(kk):
                    bh = 4.0 * nu * kn[i] / d2 * h
                    work[s, j, ef + i] = math.exp(-bh)
                    work[s, j, pf + i] = -math.expm1(-bh) / bh
                    work[s, j, cf + i] = c16 * km[i] * work[s, j, ef + i]
                    extra += h * c16 * km[i] * work[s, j, pf + i]
                work[s, j, w0 + 5] = extra
            nu = mu * rt / x[op + j]
            if abs(nu - work[s, j, w0 + 1]) > NU_TOL * nu or work[s, j, w0 + 3] != h:
                work[s, j, w0 + 1] = nu
                work[s, j, w0 + 3] = h
                sa = 0.0
                for i in range(kk):
                    bh = 4.0 * nu * kn[i] / (pc.prandtl * d2) * h
                    work[s, j, et + i] = math.exp(-bh)
                    work[s, j, pt + i] = -math.expm1(-bh) / bh
                    work[s, j, ch + i] = kappa * ka[i] * (work[s, j, et + i] - 1.0)
                    sa += ka[i] * work[s, j, pt + i]
                work[s, j, w0 + 6] = sa
    cond = np.empty((2, 2))   # (side, supply / exhaust) conductance at this command
    spool = pc.spool_order > 0.5
    for s in range(2):
        us = u if s == 0 else -u
        cond[s, 0] = interp1(us, grid, csup)
        cond[s, 1] = interp1(us, grid, cexh)
    acc.mach[:] = 0.0
    acc.exit_mach[:] = 0.0
    acc.choked[:] = 0
    acc.element[:] = 0
    for _ in range(nsub):
        if spool:
            ua = spool_step(x, u, pc)
            for s in range(2):
                us = ua if s == 0 else -ua
                cond[s, 0] = interp1(us, grid, csup)
                cond[s, 1] = interp1(us, grid, cexh)
        else:
            x[ox + X_SPOOL] = u
        vol1, vol2, _, _ = chamber_volumes(x[0], x[1], pc)
        p_c1 = x[ps[0].o_p + ps[0].nn - 1]
        p_c2 = x[ps[1].o_p + ps[1].nn - 1]
        # (1) piston
        if not pc.fixed:
            v = x[1]
            kick = 0.5 * h if start else h
            start = False
            zp = x[0] + h * x[1]
            if min(x[0], zp) < 0.0 or max(x[0], zp) > pc.stroke:
                # at an end stop: substeps resolving the stop's own oscillation
                nst = max(1, math.ceil(h * math.sqrt(pc.stop_k / mass_eff) / STOP_RESOLUTION))
                hs = h / nst
                for r in range(nst):
                    piston_step(x, hs, 0.5 * hs if (r == 0 and kick < h) else hs, p_c1, p_c2, pc, mass_eff)
                kick = h - 0.5 * hs if kick < h else h
            else:
                piston_step(x, h, kick, p_c1, p_c2, pc, mass_eff)
            _, _, _, fe = piston_forces(x[0], x[1], p_c1, p_c2, pc, True)
            acc.force = fe + (pc.env_m * (x[1] - v) / kick if pc.env_attached else 0.0)
        nvol1, nvol2, _, _ = chamber_volumes(x[0], x[1], pc)
        leak = pc.leak * (p_c1 - p_c2) if not pc.fixed else 0.0
        head = (head + 1) % nring
        for s in range(2):
            nn = ps[s].nn
            op, om, oy, ow = ps[s].o_p, ps[s].o_m, ps[s].o_y, ps[s].o_w
            bore = ps[s].bore
            area = ps[s].area
            uns = ps[s].unsteady
            the = ps[s].thermal
            m_in, _, din = orifice_flow(cond[s, 0], pc.b_crit, pc.r_lam, pc.p_supply, x[op], pc.k_ref)
            m_out, dout, _ = orifice_flow(cond[s, 1], pc.b_crit, pc.r_lam, x[op], pc.p_atm, pc.k_ref)
            mv, dmv = m_in - m_out, din - dout
            mach = 0.0
            # (2) element flows
            if ps[s].law == LAW_RESISTIVE:
                a = resistive_conductance(mv, x[op], pc, ps[s])
                for j in range(nn - 1):
                    x[om + j] = a * (x[op + j] - x[op + j + 1])
            else:
                convect = ps[s].convective
                if convect:
                    face_thrusts(x, op, om, nn, area, rt, gam, work[s, :, w0 + 4])
                inert = ps[s].inertance
                for j in range(nn - 1):
                    pa, pb, m = x[op + j], x[op + j + 1], x[om + j]
                    fs = steady_coefficient(m, mu * 2.0 * rt / (pa + pb), bore, ps[s].law, mu)
                    if convect:
                        drive = inert / area * (work[s, j, w0 + 4] - work[s, j + 1, w0 + 4])
                    else:
                        drive = inert * (pa - pb)
                    extra = 0.0
                    if uns:
                        extra = work[s, j, w0 + 5]
                        for i in range(kk):
                            drive -= work[s, j, cf + i] * x[oy + j * kk + i]
                    mn = (m * (1.0 + extra) + h * drive) / (1.0 + h * fs + extra)
                    x[om + j] = mn
                    if uns:
                        dmn = mn - m
                        for i in range(kk):
                            x[oy + j * kk + i] = x[oy + j * kk + i] * work[s, j, ef + i] + dmn * work[s, j, pf + i]
            for j in range(nn - 1):
                mj = element_mach(x[om + j], x[op + j], x[op + j + 1], j == 0, j == nn - 2, area, rt, c2)
                if mj > mach:
                    mach = mj
                    if mj > acc.mach[s]:
                        acc.element[s] = j
            acc.mach[s] = max(acc.mach[s], mach)
            if nn > 1 and ps[s].convective:
                exit_face(x[om], -1.0, x[op], area, rt, c2, gam, acc, s)
                exit_face(x[om + nn - 2], 1.0, x[op + nn - 1], area, rt, c2, gam, acc, s)
            # (3) nodes
            delayed = ps[s].attenuation
            if delayed:
                ring[s, head] = mv
                md = ring[s, (head - ps[s].delay) % nring]
                into_chamber = md * rh_attenuation(md, x[op], pc, ps[s])
                acc.valve[s] += h * mv
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
                    pn = chamber_step(p, x[ox + s], flow, g, vo, vn_, h, s, pc)
                    dm = h * (flow + g * (pn - p))
                    x[ox + s] += dm
                    if k == 0:
                        acc.valve[s] += h * (mv + g * (pn - p)) if not delayed else 0.0
                    acc.chamber[s] += dm + h * (leak if s == 0 else -leak)
                else:
                    cap = pv[s, k] / rt
                    rhs_ = h * flow
                    if the:
                        acc_w = 0.0
                        for i in range(kk):
                            acc_w += work[s, k, ch + i] * x[ow + k * kk + i]
                        rhs_ += cap * acc_w
                        dp = rhs_ / (cap * (1.0 - kappa * work[s, k, w0 + 6]) - h * g)
                        for i in range(kk):
                            x[ow + k * kk + i] = x[ow + k * kk + i] * work[s, k, et + i] + dp * work[s, k, pt + i]
                    else:
                        dp = rhs_ / (cap - h * g)
                    pn = p + dp
                    if k == 0:
                        acc.valve[s] += h * (mv + g * dp)
                x[op + k] = pn
    return head, first_bad(x, ps, vmax)


def pack_loop(nsub, h, dt, vmax, pc, ps, kn, km, ka, p_read):
    """The LOOP record of :func:`control_period` (one argument for all of it: fewer arguments make
    the per-period call from Python cheaper)."""
    loop = record(LOOP)
    r = loop[0]
    r["nsub"], r["h"], r["dt"], r["vmax"], r["p_read"] = nsub, h, dt, vmax, p_read
    r["pc"], r["ps"], r["kn"], r["km"], r["ka"] = pc[0], ps, kn, km, ka
    return loop


@njit(cache=True)
def sensor_read(value, kind, noise, resolution, draw):
    """One reading of a NoisyQuantised (value + noise draw, rounded to the resolution) or an
    Encoder (truncated to whole counts) sensor, the arithmetic of their ``read`` methods."""
    # np.floor keeps a float (numba's math.floor returns int64, which overflows past 9.2e18)
    if kind == SENSOR_ENCODER:
        return np.floor(value / resolution) * resolution
    y = value + noise * draw if noise > 0 else value
    if resolution > 0:
        y = np.floor(y / resolution + 0.5) * resolution
    return y


@njit(cache=True)
def read_sensors(k, z, force, p1, p2, p3, p4, sens_b, filt_b, noise, log_b):
    """Row k of the readings log[k].meas (MEASUREMENT_KEYS order) from the raw position, force
    and pressures: the six sensors of ``sens`` with the pre-drawn noise[k], and the two
    DifferentiatingFilter recursions of ``filt`` for velocity and acceleration, started at k = 0
    (the records as byte views, :func:`as_bytes`)."""
    sens, filt, log = sens_b.view(SENSOR), filt_b.view(FILTER), log_b.view(LOG)
    raw = (z, force, p1, p2, p3, p4)
    meas = log[k].meas
    for i in range(6):
        meas[2 + i if i > 0 else 0] = sensor_read(raw[i], sens[i].kind, sens[i].noise, sens[i].resolution,
                                                  noise[k, i])
    x = meas[0]
    for i in range(2):
        f = filt[i]
        if k == 0:
            f.x_prev = x
        f.y = f.a * f.y + f.b * (x - f.x_prev)
        f.x_prev = x
        x = f.y
        meas[i + 1] = x


@njit(cache=True)
def control_period(k, u, x, loop_b, pv, table, ring, acc_b, work, states, log_b, sens_b, filt_b, noise):
    """One control period of the fixed-rate loop (``loop``: the LOOP record of :func:`pack_loop`;
    ``table``: the valve's command grid and supply and exhaust conductances as rows): clip the
    command u to [-1, 1] into log[k].command, :func:`advance` by nsub substeps, then record row
    k's mean valve and chamber flows (kg/s over dt), peak Mach numbers and choking, and row k + 1's
    state and environment force; with compiled sensors (sens[0].kind >= 0) also row k + 1's
    readings (:func:`read_sensors`).  Returns (first bad state or -1, first side whose peak Mach
    exceeds its mach_limit or -1, then the eight readings of row k + 1 - or, without compiled
    sensors, the piston position, environment force and the pressures at the state indices
    p_read, for the Python sensors, and two zeros).  The records come as byte views (:func:`as_bytes`)."""
    r = loop_b.view(LOOP)[0]
    a = acc_b.view(ACC)[0]
    log, sens = log_b.view(LOG), sens_b.view(SENSOR)
    pc, ps = r.pc, r.ps
    u = min(1.0, max(-1.0, u))
    log[k].command = u
    a.valve[:] = 0.0
    a.chamber[:] = 0.0
    r.head, bad = advance(x, u, r.nsub, r.h, pc, ps, pv, r.kn, r.km, r.ka, table[0], table[1], table[2], ring,
                          r.head, a, r.vmax, work, k == 0)
    over = -1
    for s in range(2):
        log[k].valve[s] = a.valve[s] / r.dt
        log[k].chamber[s] = a.chamber[s] / r.dt
        log[k].mach[s] = a.mach[s]
        log[k].exit_mach[s] = a.exit_mach[s]
        log[k].choked[s] = 1.0 if a.choked[s] else 0.0
        if over < 0 and a.mach[s] > ps[s].mach_limit:
            over = s
    states[k + 1] = x
    log[k + 1].force = a.force
    pr = r.p_read
    z, f, p1, p2, p3, p4 = x[0], a.force, x[pr[0]], x[pr[1]], x[pr[2]], x[pr[3]]
    if sens[0].kind < 0.0:
        return (bad, over, z, f, p1, p2, p3, p4, 0.0, 0.0)
    read_sensors(k + 1, z, f, p1, p2, p3, p4, sens_b, filt_b, noise, log_b)
    m = log[k + 1].meas
    return (bad, over, m[0], m[1], m[2], m[3], m[4], m[5], m[6], m[7])


@njit(cache=True)
def chamber_step(p, mass, flow, g, vo, vn, h, s, pc):
    """New chamber-node pressure after one substep, the valve flow (if this node is the port)
    implicit through its slope g = d m_v / d P.  Eq 15: P V^r advanced with the polytropic form
    (mass exact for r = 1).  Energy equation (pc.energy): E = P V advanced linearly implicitly,
    E_n (1 + h (gamma - 1) h_A / (m_n R)) + (gamma - 1) P_n (V_n - V_o) = E_o + h (gamma R T_in m_dot
    + (gamma - 1) h_A T_w), which tends to P_n = m_n R T_w / V_n as h_A grows (isothermal) and to
    P V^gamma = const with h_A = 0 and no flow (adiabatic)."""
    rt = pc.rt
    if pc.energy:
        gam = pc.gamma
        r_gas = rt / pc.t_air
        t_ch = p * vo / (mass * r_gas)
        rt_in = rt if flow >= 0.0 else r_gas * t_ch
        ha = pc.wall_ha[s]
        m_n = mass + h * flow
        den = vn * (1.0 + h * (gam - 1.0) * ha / (m_n * r_gas)) + (gam - 1.0) * (vn - vo) - h * gam * rt_in * g
        return (p * vo + h * (gam * rt_in * (flow - g * p) + (gam - 1.0) * ha * pc.t_air)) / den
    r = pc.polytropic
    if r == 1.0:
        return (p * vo + h * rt * (flow - g * p)) / (vn - h * rt * g)
    fac = h * r * rt * vn ** (r - 1.0)
    return (p * vo**r + fac * (flow - g * p)) / (vn**r - fac * g)


@njit(cache=True, fastmath=FAST)
def _all_finite(x):
    """True when every x[i] is finite: x * 0 is 0 for finite x and NaN otherwise (the fast-math
    flags keep NaN and Inf, so this sum vectorises and still sees them)."""
    total = 0.0
    for i in range(x.size):
        total += x[i] * 0.0
    return total == 0.0


@njit(cache=True)
def first_bad(x, ps, vmax):
    """Index of the first non-finite or runaway state (-1 if none): pressures must stay in
    (0, 1e8) Pa and |v| below vmax."""
    if not _all_finite(x):
        for i in range(x.size):
            if not math.isfinite(x[i]):
                return i
    if abs(x[1]) > vmax:
        return 1
    for s in range(2):
        for k in range(ps[s].nn):
            p = x[ps[s].o_p + k]
            if p <= 0.0 or p > MAX_PRESSURE_PA:
                return ps[s].o_p + k
    return -1


def work_array(pv, kn):
    """Zeroed scratch array for :func:`advance`."""
    return np.zeros((2, pv.shape[1], 6 * kn.size + 7))
