"""Pressure observer (eqs 19-24): the theory of section 4.2 checked on exact models."""
import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from sensor.errors import SensorError
from sensor.pneumatic.cylinder import Cylinder, mass_spring_damper
from sensor.pneumatic.lines import DeadVolume
from sensor.pneumatic.observer import (
    ObserverModel,
    PressureObserver,
    actuator_force,
    correction,
    observer_rhs,
    volumes,
)
from sensor.pneumatic.plant import Plant
from sensor.pneumatic.sensors import ideal_sensors
from sensor.pneumatic.simulate import simulate
from sensor.pneumatic.valve import ENFIELD_LH05, port_flow

PLANT = Plant(line_1=DeadVolume(2.0), line_2=DeadVolume(2.0))
MODEL = ObserverModel.from_plant(PLANT)


def _flows(model, u, p1, p2):
    q, args = model.params, (model.grid, model.supply_conductance, model.exhaust_conductance)
    common = (q["b_crit"], q["r_lam"], q["p_supply"])
    m1 = port_flow(u, *args, *common, p1, q["p_atm"], q["k_ref"])[0]
    m2 = port_flow(-u, *args, *common, p2, q["p_atm"], q["k_ref"])[0]
    return m1, m2


def _coupled(model, z, u, k, delta=lambda t: 0.0):
    """True isothermal chambers d(P V)/dt = m R T (eq 15, r = 1) and the observer of eq 22 fed
    the true actuator force plus delta(t)."""
    q = model.params
    args = (model.grid, model.supply_conductance, model.exhaust_conductance)

    def rhs(t, y):
        v1, v2 = volumes(z(t), q)
        m1, m2 = _flows(model, u(t), y[0] / v1, y[1] / v2)
        fp = actuator_force(y[0] / v1, y[1] / v2, q) + delta(t)
        d = observer_rhs(y[2], y[3], u(t), v1, v2, fp, k, q, *args)
        return [m1 * q["rt"], m2 * q["rt"], d[0], d[1]]
    return rhs


def _solve(model, k, duration, delta=lambda t: 0.0):
    z = lambda t: 0.025 + 0.01 * math.sin(2 * math.pi * 1.3 * t)   # noqa: E731  piston motion (m)
    u = lambda t: 0.5 * math.sin(2 * math.pi * t)                    # noqa: E731  both ports, A_v1 A_v2 < 0
    v1, v2 = volumes(z(0.0), model.params)
    y0 = [2e5 * v1, 3e5 * v2, 0.0, 0.0]                              # estimates start from zero
    t = np.linspace(0.0, duration, int(duration * 1000) + 1)
    sol = solve_ivp(_coupled(model, z, u, k, delta), (0, duration), y0, method="LSODA", rtol=1e-10,
                    atol=1e-12, t_eval=t, max_step=1e-3)
    vol = np.array([volumes(z(ti), model.params) for ti in t]).T
    return t, sol.y[:2], sol.y[2:], sol.y[:2] / vol, sol.y[2:] / vol


def test_correction_term_is_eq34_at_random_states():
    # e^T e_f = k (x~1 f1 + x~2 f2) = -k (P~1 A1 - P~2 A2)^2 / (A1 A2) (eq 34), exactly, whatever the
    # cylinder, position and pressures: the volumes are known, so x~_i = P~_i V_i.
    rng = np.random.default_rng(7)
    for _ in range(200):
        bore = rng.uniform(0.008, 0.04)
        cyl = Cylinder(bore_m=bore, rod_m=rng.uniform(0.1, 0.6) * bore, stroke_m=rng.uniform(0.02, 0.2))
        plant = Plant(line_1=DeadVolume(rng.uniform(0, 10)), line_2=DeadVolume(rng.uniform(0, 10)), actuator=cyl)
        q = ObserverModel.from_plant(plant).params
        z, k = rng.uniform(0, cyl.stroke_m), rng.uniform(1e-9, 1e-5)
        p, ph = rng.uniform(1e5, 6e5, 2), rng.uniform(0, 8e5, 2)
        v1, v2 = volumes(z, q)
        f1, f2 = correction(ph[0], ph[1], v1, v2, actuator_force(p[0], p[1], q), q)
        lhs = k * ((ph[0] - p[0]) * v1 * f1 + (ph[1] - p[1]) * v2 * f2)
        pt = ph - p
        rhs = -k * (pt[0] * q["area_1"] - pt[1] * q["area_2"]) ** 2 / (q["area_1"] * q["area_2"])
        assert lhs == pytest.approx(rhs, rel=1e-9, abs=1e-12 * abs(k * pt @ pt))   # round-off only


def test_flow_part_of_the_lyapunov_derivative_is_never_positive():
    # eq 33: x~_i m~_i <= 0 for any command (the valve flow falls with the port pressure).
    rng = np.random.default_rng(3)
    for _ in range(2000):
        u = rng.uniform(-1, 1)
        p, ph = rng.uniform(0.5e5, 7e5, 2), rng.uniform(0.0, 8e5, 2)
        m = np.array(_flows(MODEL, u, *p))
        mh = np.array(_flows(MODEL, u, *ph))
        assert np.all((ph - p) * (mh - m) <= 0.0)


def test_exact_model_converges_from_zero_and_lyapunov_never_increases():
    t, x, xh, p, ph = _solve(MODEL, MODEL.gain_for_rate(10.0), 2.0)
    lyap = 0.5 * np.sum((xh - x) ** 2, axis=0)
    # L(t) of eq 26 sampled every ms never rises by more than the solver's tolerance (rtol 1e-10)
    assert np.max(np.diff(lyap)) <= 1e-9 * lyap[0]
    assert lyap[-1] < 1e-12 * lyap[0]
    assert np.max(np.abs(ph[:, -1] - p[:, -1])) < 1e-3     # Pa, from 2-3 bar initial errors


def test_correction_drives_the_force_error_to_the_valley_with_the_valve_shut():
    # Overlapped valve at u = 0: no flow, so the model part cannot correct anything (k = 0 keeps
    # the error).  With k > 0 the error dynamics is e' = -k w w^T e / (A1 A2), w = (A1/V1, -A2/V2):
    # the force error decays at rate k |w|^2 / (A1 A2) and the component along the valley of eq 36
    # is kept -- the final error is the projection of the initial one onto w's normal.
    model = ObserverModel.from_plant(Plant(valve=ENFIELD_LH05, line_1=DeadVolume(2.0), line_2=DeadVolume(2.0)))
    q, z = model.params, 0.02
    v1, v2 = volumes(z, q)
    x = np.array([3e5 * v1, 2e5 * v2])
    fp = actuator_force(3e5, 2e5, q)
    for k in (0.0, model.gain_for_rate(5.0, z)):
        obs = PressureObserver(model, "force", k, dt_s=1e-3, initial_Pa=(1e5, 4e5))
        m = {"position_m": z, "force_N": fp, "velocity_m_s": 0.0, "acceleration_m_s2": 0.0}
        for i in range(2001):
            obs.update(i * 1e-3, m, 0.0)
        e0 = np.array([1e5 * v1, 4e5 * v2]) - x
        e = np.array(obs.pressures) * (v1, v2) - x
        if k == 0.0:
            assert np.allclose(e, e0, rtol=1e-12)
        else:
            w = np.array([q["area_1"] / v1, -q["area_2"] / v2])
            kept = e0 - w * (w @ e0) / (w @ w)
            # 2 s at a 5 Hz pole: exp(-2 pi 5 * 2) leaves nothing of the decaying part
            assert np.allclose(e, kept, rtol=1e-9, atol=1e-9 * np.abs(e0).max())
            assert abs(actuator_force(*obs.pressures, q) - fp) < 1e-6


def test_bounded_force_error_keeps_the_estimate_bounded():
    # eqs 37-39: with |delta| < eps in the measured force the force estimate ends within
    # [0, delta] of the truth (so |F_hat - F*| <= eps) and the pressure error stays bounded,
    # scaling with eps (the bound is linear in delta) and not growing in time.
    k = MODEL.gain_for_rate(10.0)
    peaks = []
    for eps in (1.0, 2.0):
        t, x, xh, p, ph = _solve(MODEL, k, 3.0, lambda t, e=eps: e * math.sin(2 * math.pi * 3 * t))
        ft = actuator_force(ph[0], ph[1], MODEL.params) - actuator_force(p[0], p[1], MODEL.params)
        late = t > 1.0
        assert np.max(np.abs(ft[late])) <= eps
        err = np.max(np.abs(ph - p), axis=0)
        first, second = err[(t > 1) & (t <= 2)].max(), err[t > 2].max()
        assert second <= 1.1 * first              # bounded: no growth from one second to the next
        peaks.append(second)
    assert peaks[1] == pytest.approx(2 * peaks[0], rel=0.05)


def test_observer_in_the_loop_converges_on_an_exact_plant():
    # Plant = the observer's own model (dead-volume lines, no leak, no friction, ideal sensors):
    # from zero the estimates reach the true chamber pressures to within the discretisation
    # error of the 1 kHz observer against the plant's 0.1 ms steps: below 0.1 kPa most of the
    # time, up to ~1 kPa while a chamber nears the 6 bar supply, where the laminar end of the
    # valve law (ISO 6358, P_d/P_u > 0.999) makes the flow slope steep; bound 2 kPa (0.3 %).
    plant = Plant(line_1=DeadVolume(2.0), line_2=DeadVolume(2.0), actuator=Cylinder(leak_kg_s_Pa=0, coulomb_N=0),
                  environment=mass_spring_damper(0.0, 10000.0, 10.0, 0.025))
    model = ObserverModel.from_plant(plant)
    obs = PressureObserver(model, "force", model.gain_for_rate(10.0), initial_Pa=(0.0, 0.0))
    log, last = [], [0.0]

    def controller(t, m):
        log.append(obs.update(t, m, last[0]))
        last[0] = 0.4 * math.sin(2 * math.pi * t)
        return last[0]
    ds = simulate(plant, controller, 1.5, sensors=ideal_sensors())
    err = np.abs(np.array(log) - ds.pressure_chamber.values[:-1])
    assert err[0].max() > 1e5                    # started from zero
    assert err[1000:].max() < 2e3
    assert np.median(err[1000:]) < 100.0


def test_valve_kind_reads_the_valve_ports_and_bad_input_is_refused():
    obs = PressureObserver(MODEL, "valve")
    m = {"position_m": 0.02, "force_N": 1.0, "velocity_m_s": 0.0, "acceleration_m_s2": 0.0,
         "pressure_valve_1_Pa": 2.5e5, "pressure_valve_2_Pa": 1.5e5}
    assert obs.update(0.0, m, 0.0) == (2.5e5, 1.5e5)
    with pytest.raises(SensorError, match="observer = 'kalman'"):
        PressureObserver(MODEL, "kalman")
    with pytest.raises(SensorError, match="gain k = -1"):
        PressureObserver(MODEL, "force", -1.0)
    obs = PressureObserver(MODEL, "force", 1e-7)
    m["force_N"] = math.nan
    obs.update(0.0, m, 0.0)
    with pytest.raises(SensorError, match="P_hat_1 = nan"):
        obs.update(1e-3, m, 0.0)
