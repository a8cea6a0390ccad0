"""The pneumatic plant: supply, valve, two lines, actuator and environment (chapters III-V).

:class:`Plant` is a frozen description; :meth:`Plant.compile` turns it into
:class:`CompiledPlant`, the packed arrays the compiled kernel (:mod:`._kernel`) integrates.
Side 1 connects valve port 1 to chamber 1 (cap side), side 2 port 2 to chamber 2.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from sensor.errors import SensorInputError
from sensor.pneumatic import _kernel as K
from sensor.pneumatic.air import AIR, Air
from sensor.pneumatic.cylinder import Cylinder, Environment, FixedChambers
from sensor.pneumatic.lines import LAW_RESISTIVE, Distributed, RicherHurmuzlu
from sensor.pneumatic.unsteady import fitted_kernels
from sensor.pneumatic.valve import FESTO_MPYE, Valve

STABILITY_LIMIT = 2.0      # symplectic Euler: h omega_max < 2
DEFAULT_SAFETY = 0.5       # automatic substep: h omega_max <= 1
MAX_SUBSTEP_S = 1.0e-4     # accuracy cap on the automatic substep: lumped lines only
MAX_SUBSTEP_DISTRIBUTED_S = 2.5e-4   # ... and with a distributed line (tests/pneumatic/test_accuracy.py)
MAX_SUBSTEPS = 1e6         # substeps per control period (a bound on the work of one period)
VALVE_SAFETY = 0.5         # automatic substep: h <= 0.5 of the valve's fill time of the port node


@dataclass(frozen=True)
class Plant:
    """Supply pressure (absolute, Pa), valve, line model per side, actuator, environment."""

    supply_Pa: float = 6.0e5
    valve: Valve = FESTO_MPYE
    line_1: object = field(default_factory=lambda: Distributed(7.25))
    line_2: object = field(default_factory=lambda: Distributed(7.25))
    actuator: Cylinder | FixedChambers = field(default_factory=Cylinder)
    environment: Environment = field(default_factory=Environment)
    air: Air = AIR

    def __post_init__(self) -> None:
        if not (math.isfinite(self.supply_Pa) and self.air.atmosphere_Pa < self.supply_Pa <= K.MAX_PRESSURE_PA):
            raise SensorInputError(f"plant supply_Pa = {self.supply_Pa!r}: must be finite, above the "
                                   f"atmosphere ({self.air.atmosphere_Pa} Pa absolute) and <= "
                                   f"{K.MAX_PRESSURE_PA:g} Pa")
        for name in ("line_1", "line_2"):
            if not hasattr(getattr(self, name), "layout"):
                raise SensorInputError(f"plant {name}: must be a line model (DeadVolume, RicherHurmuzlu, "
                                       "Preliminary, TwoVolume or Distributed)")

    def compile(self) -> "CompiledPlant":
        return CompiledPlant(self)


class CompiledPlant:
    """The kernel's named records (:data:`~._kernel.COMMON` ``pc``, one :data:`~._kernel.SIDE` per side
    ``ps``), node volumes, state layout and labels of a :class:`Plant`."""

    def __init__(self, plant: Plant) -> None:
        self.plant = plant
        air, act, env = plant.air, plant.actuator, plant.environment
        kern = fitted_kernels(K.N_POLES)
        self.kn = np.asarray(kern.poles, float)
        self.km = np.asarray(kern.friction_weights, float)
        self.ka = np.asarray(kern.thermal_weights, float)
        kk = self.kn.size
        self.pc = K.record(K.COMMON)   # one record: pass self.pc[0] to the kernel
        c = self.pc[0]
        c["rt"], c["mu"], c["gamma"], c["prandtl"] = air.rt, air.viscosity_Pa_s, air.gamma, air.prandtl
        c["p_atm"], c["p_supply"], c["t_air"] = air.atmosphere_Pa, plant.supply_Pa, air.temperature_K
        c["b_crit"], c["r_lam"], c["k_ref"] = plant.valve.critical_ratio, plant.valve.laminar_ratio, plant.valve.k_ref
        if isinstance(act, FixedChambers):
            c["fixed"] = True
            c["dead_1"], c["dead_2"], c["polytropic"] = act.volume_1_m3, act.volume_2_m3, act.polytropic
            c["mass"], c["coulomb_velocity"] = 1.0, 1.0
        else:
            c["area_1"], c["area_2"], c["area_rod"] = act.area_1_m2, act.area_2_m2, act.rod_area_m2
            c["stroke"], c["dead_1"], c["dead_2"] = act.stroke_m, act.dead_volume_1_m3, act.dead_volume_2_m3
            c["mass"], c["viscous"], c["coulomb"] = act.piston_mass_kg, act.viscous_N_s_m, act.coulomb_N
            c["coulomb_velocity"], c["leak"] = act.coulomb_velocity_m_s, act.leak_kg_s_Pa
            c["stop_k"], c["stop_c"], c["polytropic"] = act.stop_stiffness_N_m, act.stop_damping_N_s_m, act.polytropic
            c["stick"] = act.stiction_N > 0
            c["static_friction"], c["stribeck_velocity"] = act.stiction_N, act.stribeck_velocity_m_s
        if act.wall_conductance_W_K is not None:
            c["energy"] = True
            c["wall_ha"] = act.wall_conductance_W_K
        if math.isfinite(plant.valve.bandwidth_Hz):
            c["spool_order"] = plant.valve.spool_order
            c["spool_w"] = 2.0 * math.pi * plant.valve.bandwidth_Hz
        c["env_attached"] = env.attached
        c["env_k"], c["env_b"], c["env_m"], c["env_z0"] = (env.stiffness_N_m, env.damping_N_s_m, env.mass_kg,
                                                          env.contact_m)
        self.layouts = (plant.line_1.layout(), plant.line_2.layout())
        nmax = max(len(lay.node_volumes_m3) for lay in self.layouts)
        self.ps = K.record(K.SIDE, 2)
        self.pv = np.zeros((2, nmax))
        self.labels: list[str] = ["piston_position", "piston_velocity"]
        pos = 2
        self.delay_s = np.zeros(2)
        for s, lay in enumerate(self.layouts):
            nn = len(lay.node_volumes_m3)
            side = self.ps[s]
            side["nn"], side["inertance"], side["bore"], side["area"] = nn, lay.inertance_m, lay.bore_m, lay.area_m2
            side["law"], side["length"], side["mach_limit"] = lay.friction_law, lay.length_m, lay.mach_limit
            side["unsteady"], side["thermal"] = lay.unsteady_friction, lay.heat_transfer
            side["attenuation"], side["convective"] = lay.attenuation, lay.convective
            if lay.attenuation:
                self.delay_s[s] = lay.length_m / air.speed_of_sound
            self.pv[s, :nn] = lay.node_volumes_m3
            nf = nn - 1
            ny = nf * kk if lay.unsteady_friction else 0
            nw = nf * kk if lay.heat_transfer else 0   # tube nodes: all but the chamber node
            side["o_p"], side["o_m"], side["o_y"], side["o_w"] = pos, pos + nn, pos + nn + nf, pos + nn + nf + ny
            tag = f"side{s + 1}"
            self.labels += [f"{tag}_pressure_{k}" for k in range(nn)]
            self.labels += [f"{tag}_flow_{j}" for j in range(nf)]
            self.labels += [f"{tag}_friction_{j}_{i}" for j in range(nf) for i in range(kk)][:ny]
            self.labels += [f"{tag}_heat_{k}_{i}" for k in range(nf) for i in range(kk)][:nw]
            pos += nn + nf + ny + nw
        c["ox"] = pos
        self.labels += ["side1_chamber_mass", "side2_chamber_mass", "spool_position", "spool_rate"]
        self.n_states = pos + K.N_EXTRA
        self.grid, self.csup, self.cexh = plant.valve.arrays()

    # --- state helpers -------------------------------------------------------------------
    def node_count(self, side: int) -> int:
        return int(self.ps[side]["nn"])

    def pressure_slice(self, side: int) -> slice:
        return slice(int(self.ps[side]["o_p"]), int(self.ps[side]["o_p"]) + self.node_count(side))

    def initial_state(self, pressure_1_Pa: float | None = None, pressure_2_Pa: float | None = None,
                      position_m: float | None = None) -> np.ndarray:
        """State at rest: uniform side pressures (default atmosphere), piston mid-stroke, gas at the
        line temperature, spool centred."""
        atm = self.plant.air.atmosphere_Pa
        x = np.zeros(self.n_states)
        for s, p in enumerate((pressure_1_Pa, pressure_2_Pa)):
            p = atm if p is None else float(p)
            if not (math.isfinite(p) and p > 0):
                raise SensorInputError(f"initial pressure_{s + 1}_Pa = {p!r}: must be a positive finite number")
            x[self.pressure_slice(s)] = p
        if isinstance(self.plant.actuator, Cylinder):
            stroke = self.plant.actuator.stroke_m
            z = stroke / 2.0 if position_m is None else float(position_m)
            if not 0.0 <= z <= stroke:
                raise SensorInputError(f"initial position_m = {z!r}: must lie within the stroke [0, {stroke}] m")
            x[0] = z
        ox = int(self.pc[0]["ox"])
        x[ox:ox + 2] = np.array([x[self.pressure_slice(s)][-1] for s in (0, 1)]) * self.chamber_volumes(x) \
            / self.plant.air.rt
        return x

    def chamber_volumes(self, x: np.ndarray) -> tuple[float, float]:
        """Total volumes (m^3) of the chamber nodes (chamber plus merged line part)."""
        v1, v2, _, _ = K.chamber_volumes(x[0], x[1], self.pc[0])
        return (v1 + self.pv[0, self.node_count(0) - 1], v2 + self.pv[1, self.node_count(1) - 1])

    def chamber_temperatures(self, x: np.ndarray) -> tuple[float, float]:
        """Gas temperature (K) of the two chamber nodes, T = P V / (m R) from the mass states (the
        line temperature for isothermal chambers)."""
        r_gas = self.plant.air.gas_constant_J_kgK
        ox = int(self.pc[0]["ox"])
        return tuple(float(x[self.pressure_slice(s)][-1] * v / (x[ox + s] * r_gas))
                     for s, v in enumerate(self.chamber_volumes(x)))

    def gas_mass(self, x: np.ndarray) -> float:
        """Total gas mass (kg) in both sides: tube nodes from P V / R T (with the heat-transfer
        correction of distributed tube nodes) plus the chamber nodes' mass states, which hold the
        mass for every polytropic r and for the energy equation (P V / R T only when r = 1)."""
        rt = self.plant.air.rt
        kappa = (self.plant.air.gamma - 1.0) / self.plant.air.gamma
        kk = self.kn.size
        ox = int(self.pc[0]["ox"])
        total = float(x[ox] + x[ox + 1])
        for s in range(2):
            nn = self.node_count(s)
            p = x[self.pressure_slice(s)][:-1]
            total += float(np.sum(p * self.pv[s, :nn - 1])) / rt
            if self.ps[s]["thermal"] and nn > 1:
                ow = int(self.ps[s]["o_w"])
                w = x[ow:ow + (nn - 1) * kk].reshape(nn - 1, kk)
                total -= float(np.sum(self.pv[s, :nn - 1] * kappa * (w @ self.ka))) / rt
        return total

    # --- dynamics ----------------------------------------------------------------------------
    def derivative(self, x: np.ndarray, command: float, hold_inlet: bool = False) -> np.ndarray:
        """Continuous dx/dt at valve command u (transport delays ignored)."""
        return K.rhs(np.asarray(x, float), float(command), self.pc[0], self.ps, self.pv, self.kn, self.km, self.ka,
                     self.grid, self.csup, self.cexh, hold_inlet)

    def omega_max(self) -> float:
        """Highest acoustic angular frequency (rad/s) of the segmented lines (adiabatic bound), or
        the fastest decay rate a R T (1/V_line + 1/V_chamber) of a resistive (preliminary) line, a
        at its largest (laminar R_t at the supply pressure)."""
        w = 0.0
        air = self.plant.air
        c2 = air.gamma * air.rt
        vch = self.chamber_volumes(self.initial_state())
        for s in range(2):
            nn = self.node_count(s)
            if nn < 2:
                continue
            vols = self.pv[s, :nn].copy()
            vols[-1] = vch[s]
            if self.ps[s]["law"] == LAW_RESISTIVE:
                a = K.resistive_conductance(0.0, self.plant.supply_Pa, self.pc[0], self.ps[s])
                w = max(w, a * air.rt * (1.0 / vols[0] + 1.0 / vols[-1]))
                continue
            inc = np.zeros((nn - 1, nn))
            inc[np.arange(nn - 1), np.arange(nn - 1)] = 1.0
            inc[np.arange(nn - 1), np.arange(1, nn)] = -1.0
            stiff = self.ps[s]["inertance"] * c2 * inc @ np.diag(1.0 / vols) @ inc.T
            w = max(w, float(np.sqrt(np.max(np.linalg.eigvalsh(stiff)))))
        return w

    def valve_fill_time_s(self) -> float:
        """Shortest time (s) the valve, fully open, takes to move a side's port node across the
        span from atmosphere to supply: V_0 (P_s - P_atm) / (R T m_max), m_max = C_max k_ref P_s
        the choked flow of its largest conductance (eq 14, Appendix A); inf without a valve."""
        cmax = float(max(np.max(self.csup), np.max(self.cexh)))
        if cmax <= 0:
            return math.inf
        air, p_s = self.plant.air, self.plant.supply_Pa
        m_max = cmax * self.plant.valve.k_ref * p_s
        vch = self.chamber_volumes(self.initial_state())
        v0 = [self.pv[s, 0] + (vch[s] - self.pv[s, 0] if self.node_count(s) == 1 else 0.0) for s in (0, 1)]
        return min(v0) * (p_s - air.atmosphere_Pa) / (air.rt * m_max)

    def substeps(self, dt_s: float, substep_s: float | None = None) -> tuple[int, float]:
        """(count, length) of the substeps that cover one control period dt_s.

        Automatic: h <= min(1 / omega_max, VALVE_SAFETY x :meth:`valve_fill_time_s`, cap), the cap
        MAX_SUBSTEP_DISTRIBUTED_S when a side has a distributed line (the lumped parts' error at
        that substep stays far below the line's own) and MAX_SUBSTEP_S otherwise.  1 / omega_max
        also bounds the convective time scale: waves run at c + |u| with |u| <= sqrt(R T) (the
        isothermal choke of the end faces), which raises omega_max by 1 + 1/sqrt(gamma) = 1.85 and
        keeps h (1.85 omega_max) = 1.85 inside the stability limit 2.  The valve's fill time bounds
        a large valve, which otherwise moves the port node from atmosphere to supply within one
        substep (100 times the Festo valve on a 1 m, 20-segment line: 1.7 us).  A requested
        ``substep_s`` above the stability limit 2 / omega_max raises SensorError."""
        if not (math.isfinite(dt_s) and dt_s > 0):
            raise SensorInputError(f"time step dt_s = {dt_s!r}: must be a positive finite number")
        wmax = self.omega_max()
        limit = STABILITY_LIMIT / wmax if wmax > 0 else math.inf
        if substep_s is None:
            distributed = any(isinstance(line, Distributed) for line in (self.plant.line_1, self.plant.line_2))
            h_target = min(DEFAULT_SAFETY * limit, VALVE_SAFETY * self.valve_fill_time_s(),
                           MAX_SUBSTEP_DISTRIBUTED_S if distributed else MAX_SUBSTEP_S)
        else:
            h_target = float(substep_s)
            if not (math.isfinite(h_target) and h_target > 0):
                raise SensorInputError(f"substep_s = {substep_s!r}: must be a positive finite number")
            if h_target > limit:
                raise SensorInputError(
                    f"substep_s = {h_target:.3g} s: exceeds the stability limit {limit:.3g} s of the "
                    f"segmented line (2 / omega_max, omega_max = {wmax:.4g} rad/s); use fewer segments "
                    "or a smaller substep")
        if not dt_s / h_target <= MAX_SUBSTEPS:
            raise SensorInputError(f"time step dt_s = {dt_s!r}: needs {dt_s / h_target:.3g} substeps of "
                                   f"{h_target:.3g} s; must be <= {MAX_SUBSTEPS:g} (raise the control rate)")
        n = max(1, math.ceil(dt_s / h_target - 1e-9))
        return n, dt_s / n

    def linear_line_model(self, mean_pressure_Pa: float, side: int = 0) -> "ModalResponse":
        """Linearised line of one side: p_end / p_inlet as a sum of modes.

        The plant's own right-hand side is linearised numerically (central differences) about
        rest at ``mean_pressure_Pa`` with the valve shut and the inlet (valve-port) pressure
        imposed; the state matrix is diagonalised once.  Requires FixedChambers."""
        if not isinstance(self.plant.actuator, FixedChambers) or self.pc[0]["energy"]:
            raise SensorInputError("linear_line_model needs FixedChambers with eq 15 (no energy equation) "
                                   "as the actuator")
        line = (self.plant.line_1, self.plant.line_2)[side]
        if isinstance(line, RicherHurmuzlu):
            # its delay and attenuation act on the valve flow, outside the state equations: a
            # linearisation of the right-hand side would wrongly return 1
            raise SensorInputError("linear_line_model: a RicherHurmuzlu line has no state-space "
                              "linearisation (delay and attenuation); use its analytic response")
        nn = self.node_count(side)
        if nn < 2:
            return ModalResponse(np.zeros(0, complex), np.zeros(0, complex), 1.0)
        x0 = self.initial_state(mean_pressure_Pa, mean_pressure_Pa)
        u_shut = self._shut_command()
        inlet = int(self.ps[side]["o_p"])
        block_end = int(self.ps[1]["o_p"]) if side == 0 else int(self.pc[0]["ox"])
        idx = np.arange(inlet + 1, block_end)   # this side's states except the imposed inlet
        pa_like = np.array([("pressure" in lab or "heat" in lab) for lab in self.labels])
        steps = np.where(pa_like, 1.0, 1e-8)
        cols = []
        for i in np.append(idx, inlet):
            xp, xm = x0.copy(), x0.copy()
            xp[i] += steps[i]
            xm[i] -= steps[i]
            d = self.derivative(xp, u_shut, True) - self.derivative(xm, u_shut, True)
            cols.append(d[idx] / (2 * steps[i]))
        a = np.column_stack(cols[:-1])
        lam, vec = np.linalg.eig(a)
        left = np.linalg.solve(vec, cols[-1])   # modal input weights
        return ModalResponse(lam, vec[nn - 2, :] * left, 0.0)

    def linear_line_response(self, frequency_Hz, mean_pressure_Pa: float, side: int = 0) -> np.ndarray:
        """Complex p_end / p_inlet at each frequency (Hz), see :meth:`linear_line_model`."""
        return self.linear_line_model(mean_pressure_Pa, side)(frequency_Hz)

    def _shut_command(self) -> float:
        """A command at which no valve orifice is open, else 0 (the centre)."""
        grid = self.grid
        shut = grid[(self.csup == 0) & (self.cexh[::-1] == 0) & (self.cexh == 0) & (self.csup[::-1] == 0)]
        return float(shut[np.argmin(np.abs(shut))]) if shut.size else 0.0


@dataclass(frozen=True)
class ModalResponse:
    """H(j w) = direct + sum_k residues_k / (j w - poles_k) (poles in rad/s)."""

    poles: np.ndarray
    residues: np.ndarray
    direct: float

    def __call__(self, frequency_Hz) -> np.ndarray:
        w = 2 * np.pi * np.asarray(frequency_Hz, float)
        terms = self.residues[None, :] / (1j * w.reshape(-1, 1) - self.poles[None, :])
        return (self.direct + terms.sum(axis=1)).reshape(w.shape)
