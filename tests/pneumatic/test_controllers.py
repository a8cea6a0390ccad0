"""Controllers of chapters IV-V: sat of DESIGN section 12, references, the inverse valve
calibration, the SMC equivalent input against the flow model, the line model, closed loops, the
gains derived per line length (section 5.4.2)."""
import json
import math
from dataclasses import replace

import numpy as np
import pytest

from sensor.errors import SensorError
from sensor.pneumatic.controllers import (
    Impedance,
    calibration_inverse,
    command_for,
    line_dynamics,
    line_model_gains,
    parse_reference,
    sat,
    smc_conductance,
    smc_gains,
)
from sensor.pneumatic.lines import DeadVolume
from sensor.pneumatic.observer import (
    Q_A1,
    Q_A2,
    Q_RT,
    ObserverModel,
    PressureObserver,
    volumes,
)
from sensor.pneumatic.plant import Plant
from sensor.pneumatic.studies import Setup, build_plant, metrics, run
from sensor.pneumatic.valve import ENFIELD_LH05, FESTO_MPYE


def test_sat_is_the_corrected_eq52():
    phi = 3.0
    assert sat(1.5, phi) == 0.5 and sat(-1.5, phi) == -0.5          # s / phi inside the layer
    assert sat(10.0, phi) == 1.0 and sat(-10.0, phi) == -1.0         # sign(s) outside (both sides)
    assert sat(phi, phi) == 1.0 and sat(-phi, phi) == -1.0           # continuous at the edges
    assert sat(phi * (1 + 1e-12), phi) == 1.0


def test_references_values_rates_and_bad_text():
    r = parse_reference("sine:2Hz", 24.0, 5.0)
    t = 0.123
    assert r.value(t) == pytest.approx(5 + 24 * math.sin(4 * math.pi * t))
    assert r.rate(t) == pytest.approx((r.value(t + 1e-6) - r.value(t - 1e-6)) / 2e-6, rel=1e-6)
    sq = parse_reference("square:0.5Hz", 10.0)
    assert sq.value(0.5) == 10.0 and sq.value(1.5) == -10.0 and sq.peak_N == (-10.0, 10.0)
    st = parse_reference("step", 7.0)
    assert st.value(0.49) == 0.0 and st.value(0.5) == 7.0
    for bad in ("tri:1Hz", "sine:xHz", "sine:-1Hz", ""):
        with pytest.raises(SensorError, match="reference"):
            parse_reference(bad)


@pytest.mark.parametrize("valve", [FESTO_MPYE, ENFIELD_LH05])
def test_inverse_calibration_returns_the_command(valve):
    # Independent: the valve's own conductance table at u, inverted, gives u back (outside the
    # closed / leakage band, where a conductance has no unique command).
    model = ObserverModel.from_plant(Plant(valve=valve, line_1=DeadVolume(1.0), line_2=DeadVolume(1.0)))
    cal_c, cal_u = calibration_inverse(model)
    for u in np.linspace(-1, 1, 81):
        if abs(u) <= cal_u[0] + 1e-12:
            continue
        c = valve.conductances(abs(u))[0] * np.sign(u)
        assert command_for(c, cal_c, cal_u) == pytest.approx(u, abs=1e-12)
    assert command_for(0.0, cal_c, cal_u) == cal_u[0]


def test_smc_equivalent_conductance_gives_the_requested_force_rate():
    # Eqs 47/51/53 with R T: the signed conductance, put through the valve model at the command it
    # maps to, makes F_p' = A1 P1' - A2 P2' (eq 15, isothermal, moving volumes) equal the request.
    plant = Plant(valve=ENFIELD_LH05, line_1=DeadVolume(2.0), line_2=DeadVolume(2.0))
    model = ObserverModel.from_plant(plant)
    q = model.q
    cal_c, cal_u = calibration_inverse(model)
    rng = np.random.default_rng(1)
    checked = 0
    for _ in range(300):
        p1, p2 = rng.uniform(1.2e5, 5e5, 2)
        z, v, rate = rng.uniform(0.005, 0.045), rng.uniform(-0.05, 0.05), rng.uniform(-3000, 3000)
        c = smc_conductance(rate, p1, p2, z, v, q)
        u = command_for(c, cal_c, cal_u)
        if abs(u) >= 1.0 or abs(u) <= cal_u[0]:
            continue            # beyond the valve's capacity or inside its closed band
        v1, v2 = volumes(z, q)
        m1 = plant.valve.mass_flow(u, plant.supply_Pa, p1, 1)
        m2 = plant.valve.mass_flow(u, plant.supply_Pa, p2, 2)
        dp1 = (m1 * q[Q_RT] - p1 * q[Q_A1] * v) / v1
        dp2 = (m2 * q[Q_RT] + p2 * q[Q_A2] * v) / v2
        assert q[Q_A1] * dp1 - q[Q_A2] * dp2 == pytest.approx(rate, rel=1e-9, abs=1e-6)
        checked += 1
    assert checked > 100


def test_line_model_estimate_tracks_a_two_volume_plant():
    # Plant lines = the controller's own two-volume model (eqs 54-58): its chamber-pressure
    # estimate from the valve-port readings follows the truth to within the pressure sensors'
    # noise (200 Pa) and its own 1 ms semi-implicit steps: RMS below 1 kPa.
    s = Setup(controller="line-model", observer="standard", reference="sine:1Hz", amplitude_N=10.0,
              line_length_m=5.0, line_model="two-volume", valve="enfield-lh05", duration_s=3.0)
    ds = run(s)
    err = ds.line_model_pressure_1_Pa - ds.pressure_chamber.sel(side=1)
    assert float((err[500:-1] ** 2).mean() ** 0.5) < 1e3
    assert np.all(ds.h_bar_per_s[:-1] > 0)


@pytest.mark.parametrize("controller,valve,length", [("pi", "festo-mpye-5-1/8-lf", 1.0), ("smc", "enfield-lh05", 2.0)])
def test_closed_loop_step_tracking_on_a_short_line(controller, valve, length):
    # 10 N step at 0.5 s on a short distributed line: the contact force settles on the reference
    # (last 0.5 s mean within 0.5 N, i.e. 5 %; noise of the load cell 0.02 N).
    s = Setup(controller=controller, observer="force", reference="step", amplitude_N=10.0, line_length_m=length,
              segments=4, valve=valve, duration_s=2.0)
    ds = run(s)
    late = ds.environment_force.sel(time=slice(1.5, None))
    assert abs(float(late.mean()) - 10.0) < 0.5
    assert metrics(ds, s.ref)["force_mse_N2"] < 25.0       # the step itself: error 10 N for tens of ms


def _line_model_on_own_model(gains):
    s = Setup(controller="line-model", observer="standard", reference="sine:1Hz", line_length_m=2.0,
              line_model="two-volume", valve="enfield-lh05", duration_s=4.0, gains=gains)
    ds = run(s)
    return metrics(ds, s.ref), ds


def test_line_model_outer_loop_needs_the_line_inertia_on_a_2m_line():
    # Plant lines = the controller's own two-volume model (eqs 54-58), so only the design is
    # tested.  At 2 m w_L = sqrt((A/L) R T / V) ~ 170 rad/s >> the line friction f ~ 20-50 /s,
    # the case section 5.3.1's "dm_c/dt neglected" does not cover: eq 70 as written (k_m = 0)
    # limit-cycles (force MSE > 100 N^2 for a 24 N, 1 Hz sine), with the flow term (k_m =
    # 400 /s, above w_L so the line resonance is damped) it tracks: MSE_1 below 0.5 N^2 and no
    # limit cycle: no spectral line of the force error above 2.5 Hz (past the reference's
    # harmonics) over 0.2 N (the limit cycle of eq 70 as written has tens of newtons; measured
    # with the flow term: 0.03 N, MSE_1 0.006 N^2).
    base = (("kp1", 0.1), ("kp2_per_s", 200.0))
    bad, _ = _line_model_on_own_model(base + (("flow_rate_per_s", 0.0),))
    good, ds = _line_model_on_own_model(base + (("flow_rate_per_s", 400.0),))
    assert bad["force_mse_N2"] > 100.0
    assert good["force_mse_N2"] < 0.5 and good["virtual_input_mse_N2"] < 0.5
    w = ds.sel(time=slice(2.0, 3.998))
    e = (w.desired_force_N - w.environment_force).values
    amplitude = 2 * np.abs(np.fft.rfft(e - e.mean())) / e.size
    freq = np.fft.rfftfreq(e.size, 1e-3)
    assert amplitude[freq > 2.5].max() < 0.2


def test_default_line_model_gains_do_not_oscillate_on_a_5m_distributed_line():
    # The defaults of section 5.4.2 (line_model_gains) on the 20-segment distributed 5 m line,
    # Enfield valve, 24 N 1 Hz sine.  The inner loop (eq 72) assumes the half line volume at the
    # port; at one-sample time scales the port sees the line's wave impedance, and too high a
    # k_p2 makes the command flip sign every sample (a 500 Hz limit cycle that saturates the
    # valve: measured with k_p2 = 60 /s, 76 % of samples saturated, MSE_2 ~ 1500 N^2).  Checked
    # against that failure: no saturated sample, the force error's spectrum above 2.5 Hz (past
    # the reference's harmonics) under 0.5 N (measured 0.22 N; the limit cycle: 3.3 N), no
    # line of the inner-loop error F_vd - F_V above 100 Hz over 0.5 N, and MSE_1 < 2 N^2
    # (measured 0.65; inner-loop line 0.1 N, 0.57 N at k_p2 = 34 /s).  The gains are the derived ones.
    s = Setup(controller="line-model", observer="standard", reference="sine:1Hz", line_length_m=5.0,
              valve="enfield-lh05", duration_s=3.0)
    ds = run(s)
    assert json.loads(ds.attrs["gains"]) == line_model_gains(build_plant(s))
    w = ds.sel(time=slice(1.0, 2.998))
    assert float(np.mean(np.abs(w.command) >= 0.999)) == 0.0
    freq = np.fft.rfftfreq(w.sizes["time"], 1e-3)
    for signal, above in (((w.desired_force_N - w.environment_force).values, 2.5),
                          ((w.virtual_input_desired_N - w.virtual_input_N).values, 100.0)):
        amplitude = 2 * np.abs(np.fft.rfft(signal - signal.mean())) / signal.size
        assert amplitude[freq > above].max() < 0.5
    assert metrics(ds, s.ref)["force_mse_N2"] < 2.0


def test_gains_follow_the_line_dynamics():
    # Independent check of line_dynamics: w_L^2 = (A/L) R T / V_bar by hand for the 16 mm
    # cylinder and 4 mm lines; the derived gains scale as documented: eta/phi = w_L / 7,
    # k_m = 2 w_L, lambda + h_bar k_p1 = 0.75 w_L, one k_p2 = 0.8 c / 10 m up to 10 m.
    for length in (2.0, 10.0):
        plant = build_plant(Setup(line_length_m=length, valve="enfield-lh05"))
        ld = line_dynamics(plant)
        act, rt = plant.actuator, plant.air.rt
        area = math.pi * 0.004**2 / 4
        vbar = 0.5 * (act.dead_volume_1_m3 + act.dead_volume_2_m3) + 0.5 * (act.area_1_m2 + act.area_2_m2) * act.stroke_m / 2 \
            + area * length / 2
        assert ld.natural_rad_s == pytest.approx(math.sqrt(area / length * rt / vbar), rel=1e-12)
        smc, lm = smc_gains(plant), line_model_gains(plant)
        assert smc["eta_N_s"] / smc["phi_N"] == pytest.approx(ld.natural_rad_s / 7)
        assert lm["flow_rate_per_s"] == pytest.approx(2 * ld.natural_rad_s)
        assert lm["lam_per_s"] + ld.h_bar_per_s * lm["kp1"] == pytest.approx(0.75 * ld.natural_rad_s)
        assert lm["kp2_per_s"] == pytest.approx(0.8 * plant.air.speed_of_sound / 10.0)


def test_reference_higher_rates_match_finite_differences():
    r = parse_reference("sine:1.5Hz", 24.0, 3.0)
    h, t = 1e-4, 0.377
    d1 = lambda x: (r.value(x + h) - r.value(x - h)) / (2 * h)          # noqa: E731
    d2 = lambda x: (d1(x + h) - d1(x - h)) / (2 * h)                    # noqa: E731
    # central differences: relative truncation error ~ (w h)^2 / 6 ~ 1e-7, rounding ~ 1e-16 / h^n
    assert r.rate(t, 2) == pytest.approx(d2(t), rel=1e-4)
    assert r.rate(t, 3) == pytest.approx((d2(t + h) - d2(t - h)) / (2 * h), rel=1e-3)
    assert parse_reference("square:1Hz").rate(0.3, 2) == 0.0


def test_impedance_force_is_eq42_with_the_moving_z_d():
    # Eq 42 with z~ = z_d - z (eq 41): for a sine z_d the derivatives of z~ include z_d', z_d''
    # (by finite differences of z_d(t), independent of Reference.rate); the rate handed to the SMC
    # is the reference part of F_d', d/dt of k_d z_d + b_d z_d' + m_d z_d'' at fixed measurements.
    plant = build_plant(Setup(valve="enfield-lh05"))
    model = ObserverModel.from_plant(plant)
    ref = parse_reference("sine:1.5Hz", 24.0)
    imp = Impedance(model, ref, PressureObserver(model, "valve"), 1e-3)
    zd = lambda x: imp.rest + ref.value(x) / imp.kd                     # noqa: E731
    h, t = 1e-4, 0.61
    m = {"position_m": 0.0262, "velocity_m_s": -0.031, "acceleration_m_s2": 0.4}
    zd1 = (zd(t + h) - zd(t - h)) / (2 * h)
    zd2 = (zd(t + h) - 2 * zd(t) + zd(t - h)) / h**2
    fd, rate = imp.desired(t, m)
    expected = imp.md * (zd2 - 0.4) + imp.bd * (zd1 + 0.031) + imp.kd * (zd(t) - 0.0262)
    assert fd == pytest.approx(expected, abs=1e-4)        # N; finite-difference error ~1e-6 N
    assert rate == pytest.approx((imp.desired(t + h, m)[0] - imp.desired(t - h, m)[0]) / (2 * h), rel=1e-4)


def test_smc_impedance_on_7m_lines_does_not_limit_cycle():
    # Section 4.3 (Figure 26 setting): SMC impedance control, observer on, 7.25 m distributed
    # lines, Enfield valve, z_d a 1.5 Hz sine.  With the measured part of F_d' (-k_d z' - b_d z'')
    # fed forward, the loop limit-cycled at ~23.5 Hz ~ c / (2 L) (the lines' round trip): piston
    # velocity 0.27 m/s RMS, force error 21 N RMS, for every eta tried.  Now: no line of the force
    # error above 5 Hz over 0.5 N (measured 0.03 N; the limit cycle: 21 N at 23 Hz) and the piston
    # velocity that of the 1.5 Hz motion (3.8 mm amplitude: 0.025 m/s RMS; measured 0.026) below 0.03 m/s.
    s = Setup(controller="smc", observer="force", reference="sine:1.5Hz", valve="enfield-lh05", duration_s=3.0)
    model = ObserverModel.from_plant(build_plant(s))
    imp = Impedance(model, s.ref, PressureObserver(model, "valve"), 1e-3)
    ds = run(replace(s, gains=(("impedance", imp),)))
    w = ds.sel(time=slice(1.0, 2.998))
    e = (w.desired_force_N - w.environment_force).values
    amplitude = 2 * np.abs(np.fft.rfft(e - e.mean())) / e.size
    freq = np.fft.rfftfreq(e.size, 1e-3)
    assert amplitude[freq > 5.0].max() < 0.5
    assert float(w.piston_velocity.std()) < 0.03
