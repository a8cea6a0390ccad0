"""Controllers of chapters IV-V: sat of DESIGN section 12, references, the inverse valve
calibration, the SMC equivalent input against the flow model, the line model, closed loops, the
gains derived per line length (section 5.4.2)."""
import json
import math
from dataclasses import replace

import numpy as np
import pytest

from sensor.errors import SensorError, SensorInputError
from sensor.pneumatic.controllers import (
    Impedance,
    command_for,
    line_dynamics,
    line_model_gains,
    parse_reference,
    sat,
    smc_conductance,
    smc_gains,
    valve_inverse,
)
from sensor.pneumatic.experiment import LOOP_SUBSTEP_S, Setup, build_plant, run
from sensor.pneumatic.lines import DeadVolume
from sensor.pneumatic.loop_metrics import metrics
from sensor.pneumatic.observer import (
    ObserverModel,
    PressureObserver,
    volumes,
)
from sensor.pneumatic.plant import Plant
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
    cal_c, cal_u = valve_inverse(model)
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
    q = model.params
    cal_c, cal_u = valve_inverse(model)
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
        dp1 = (m1 * q["rt"] - p1 * q["area_1"] * v) / v1
        dp2 = (m2 * q["rt"] + p2 * q["area_2"] * v) / v2
        assert q["area_1"] * dp1 - q["area_2"] * dp2 == pytest.approx(rate, rel=1e-9, abs=1e-6)
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
              segments=4, valve=valve, duration_s=2.0, step_s=0.5)
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
    base = (("kp1", 0.1), ("kp2_per_s", 200.0), ("ki2_per_s2", 0.0))
    bad, _ = _line_model_on_own_model(base + (("flow_rate_per_s", 0.0),))
    good, ds = _line_model_on_own_model(base + (("flow_rate_per_s", 400.0),))
    assert bad["force_mse_N2"] > 100.0
    assert good["force_mse_N2"] < 0.5 and good["virtual_input_mse_N2"] < 0.5
    w = ds.sel(time=slice(2.0, 3.998))
    e = (w.desired_force_N - w.environment_force).values
    amplitude = 2 * np.abs(np.fft.rfft(e - e.mean())) / e.size
    freq = np.fft.rfftfreq(e.size, 1e-3)
    assert amplitude[freq > 2.5].max() < 0.2


def test_default_damped_line_model_gains_do_not_oscillate_on_a_5m_distributed_line():
    # Our line-model controller (line_model_gains "damped": k_m = 2 w_L) on the 20-segment distributed 5 m line,
    # Enfield valve, 24 N 1 Hz sine.  The inner loop (eq 72) assumes the half line volume at the
    # port; at one-sample time scales the port sees the line's wave impedance, and too high a
    # k_p2 makes the command flip sign every sample (a 500 Hz limit cycle that saturates the
    # valve: measured with k_p2 = 60 /s, 76 % of samples saturated, MSE_2 ~ 1500 N^2).  Checked
    # against that failure: no saturated sample, the force error's spectrum above 2.5 Hz (past
    # the reference's harmonics) under 0.5 N (measured 0.22 N; the limit cycle: 3.3 N), no
    # line of the inner-loop error F_vd - F_V above 100 Hz over 0.5 N, and MSE_1 < 2 N^2
    # (measured 0.65; inner-loop line 0.1 N, 0.57 N at k_p2 = 34 /s).  The gains are the derived ones.
    s = Setup(controller="line-model-damped", observer="standard", reference="sine:1Hz", line_length_m=5.0,
              valve="enfield-lh05", duration_s=3.0)
    ds = run(s)
    assert json.loads(ds.attrs["gains"]) == line_model_gains(build_plant(s), "damped")
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
    # k_m = 0 as eqs 70/72 (thesis) or 2 w_L (damped), lambda + h_bar k_p1 = 0.75 w_L, one
    # k_p2 = 0.8 c / 10 m up to 10 m, k_i2 = k_p2^2 / 4 (eq 73 critically damped).
    for length in (2.0, 10.0):
        plant = build_plant(Setup(line_length_m=length, valve="enfield-lh05"))
        ld = line_dynamics(plant)
        act, rt = plant.actuator, plant.air.rt
        area = math.pi * 0.004**2 / 4
        vbar = 0.5 * (act.dead_volume_1_m3 + act.dead_volume_2_m3) + 0.5 * (act.area_1_m2 + act.area_2_m2) * act.stroke_m / 2 \
            + area * length / 2
        assert ld.natural_rad_s == pytest.approx(math.sqrt(area / length * rt / vbar), rel=1e-12)
        smc, lm, damped = smc_gains(plant), line_model_gains(plant), line_model_gains(plant, "damped")
        assert smc["eta_N_s"] / smc["phi_N"] == pytest.approx(ld.natural_rad_s / 7)
        assert lm["flow_rate_per_s"] == 0.0
        assert damped["flow_rate_per_s"] == pytest.approx(2 * ld.natural_rad_s)
        assert {k: v for k, v in damped.items() if k != "flow_rate_per_s"} == {k: v for k, v in lm.items()
                                                                               if k != "flow_rate_per_s"}
        assert lm["ki2_per_s2"] == pytest.approx(lm["kp2_per_s"] ** 2 / 4)
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


def _synthetic_run(error_N, rate_Hz=1000.0, duration_s=10.0):
    """A dataset with what squared_errors reads: F_d = 10 sin(2 pi t), F_e = F_d - error(t),
    exact estimates (zero pressure error)."""
    import xarray as xr
    t = np.arange(int(duration_s * rate_Hz) + 1) / rate_Hz
    fd = 10 * np.sin(2 * np.pi * t)
    p = np.full((t.size, 2), 3e5)
    return xr.Dataset({"desired_force_N": ("time", fd), "environment_force": ("time", fd - error_N(t)),
                       "estimated_pressure_1_Pa": ("time", p[:, 0]), "estimated_pressure_2_Pa": ("time", p[:, 1]),
                       "pressure_chamber": (("time", "side"), p), "pressure_valve": (("time", "side"), p)},
                      coords={"time": t, "side": [1, 2]})


@pytest.mark.parametrize("tau_s,settled", [(0.5, True), (20.0, False)])
def test_settling_rule_against_a_known_decay(tau_s, settled):
    # Force error e = 0.3 N + exp(-t / tau) sin(6 pi t): the per-cycle MSE of cycle k is about
    # 0.09 + 1/2 exp(-2 t / tau) over the cycle -- computed here by hand, independently; a 20 s
    # run, the rule reads cycles 10-19.  tau = 0.5 s: the decay has died out (the two 5-cycle
    # averages differ by < 1e-9); tau = 20 s: cycles 10-14 average ~0.24 N^2, cycles 15-19 ~0.18
    # N^2: 25 % apart, beyond 10 %.  (A 3 Hz error on a 1 Hz reference is periodic with it.)
    from sensor.pneumatic.controllers import Reference
    from sensor.pneumatic.loop_metrics import per_cycle
    ds = _synthetic_run(lambda t: 0.3 + np.exp(-t / tau_s) * np.sin(6 * np.pi * t), duration_s=20.0)
    ref = Reference("sine", 1.0, 10.0)
    m = metrics(ds, ref)
    cyc = per_cycle(ds, 1.0)["force_mse_N2"]
    t = np.linspace(0, 20, 200001)
    e2 = (0.3 + np.exp(-t / tau_s) * np.sin(6 * np.pi * t)) ** 2
    by_hand = [e2[(t >= k) & (t < k + 1)].mean() for k in range(20)]
    assert cyc == pytest.approx(by_hand, rel=1e-3)
    assert m["settled"] is settled
    assert m["limit_cycle"] is False and m["status"] == ("settled" if settled else "unsettled")
    assert m["window_s"] == [18.0, 20.0]
    assert m["force_mse_N2"] == pytest.approx(np.mean(by_hand[18:]), rel=1e-3)


def test_settling_rule_has_a_relative_bound_and_no_standard_error_escape():
    # A constant error whose size scatters from cycle to cycle: the two 5-cycle MSE averages
    # (computed here from the sizes) decide alone - within 10 % settles, beyond does not, however
    # large the scatter within the blocks (the old rule let a 2-standard-error change pass).
    from sensor.pneumatic.controllers import Reference
    ref = Reference("sine", 1.0, 10.0)
    for seed in range(8):
        size = 1.0 + 0.1 * np.random.default_rng(seed).standard_normal(10)
        mse = size**2
        change = abs(mse[5:].mean() - mse[:5].mean()) / max(mse[5:].mean(), mse[:5].mean())
        m = metrics(_synthetic_run(lambda t: size[np.minimum(t.astype(int), 9)]), ref)
        assert m["settled"] is bool(change <= 0.10) and m["limit_cycle"] is False
    noisy = 1.0 + 0.5 * np.random.default_rng(4).standard_normal(10)   # wide scatter, blocks 39 % apart
    mse = noisy**2
    assert abs(mse[5:].mean() - mse[:5].mean()) / max(mse[5:].mean(), mse[:5].mean()) > 0.10
    assert metrics(_synthetic_run(lambda t: noisy[np.minimum(t.astype(int), 9)]), ref)["status"] == "unsettled"


def _blocky(sizes):
    """A synthetic run whose constant error takes size sizes[k] in second k (1 Hz cycles)."""
    sizes = np.asarray(sizes, float)
    return _synthetic_run(lambda t: sizes[np.minimum(t.astype(int), sizes.size - 1)])


def test_noise_free_twin_settles_only_a_run_that_fails_on_its_scatter():
    # The run's per-cycle error sizes give block MSE means 1.0 and 1.25 N^2 (20 % apart: fails
    # the 10 % bound).  Its twin with constant sizes (0 % apart) settles it, reporting the run's
    # own 20 % change; a twin that itself scatters as much, or carries a steady 3.1 Hz, 5 N
    # oscillation on the 24 N reference (a limit cycle), leaves it unsettled; a run that settles
    # by itself never reads the twin (its twin here would fail).
    from sensor.pneumatic.controllers import Reference
    from sensor.pneumatic.loop_metrics import metrics as run_metrics
    ref = Reference("sine", 1.0, 24.0)
    scattered = [1.0] * 5 + [np.sqrt(1.25)] * 5
    steady = _blocky([1.0] * 10)
    m = run_metrics(_blocky(scattered), ref, twin=steady)
    assert m["status"] == "settled" and m["settled_by"] == "noise_free_twin"
    assert m["noise_block_change"] == pytest.approx(0.25 / 1.25, rel=1e-3)
    assert run_metrics(_blocky(scattered), ref)["status"] == "unsettled"
    assert run_metrics(_blocky(scattered), ref, twin=_blocky(scattered))["status"] == "unsettled"
    cycling = _synthetic_run(lambda t: 1.0 + 5.0 * np.sin(2 * np.pi * 3.1 * t))
    assert run_metrics(_blocky(scattered), ref, twin=cycling)["status"] == "unsettled"
    own = run_metrics(steady, ref, twin=_blocky(scattered))
    assert own["settled_by"] == "run" and "noise_free_twin" not in own["settling"]


def test_a_noise_driven_run_is_settled_by_its_noise_free_twin():
    # Chapter V's damped line model at 7.25 m, 0.5 Hz (50 s): the closed loop's 15-30 Hz
    # response to the sensors' white noise makes its 5-cycle force-MSE blocks differ by more than
    # the 10 % bound (13.5 % measured); the same setup with ideal sensors converges (blocks
    # within 0.05 %, measured): settled by the twin.  Bound on the twin 1 % (20x the measured).
    from sensor.pneumatic.experiment import measure
    s = Setup(controller="line-model-damped", observer="standard", reference="sine:0.5Hz", line_length_m=7.25,
              valve="enfield-lh05", duration_s=50.0)
    m = measure(s, run(s))
    assert m["status"] == "settled" and m["settled_by"] == "noise_free_twin"
    assert m["noise_block_change"] > 0.10
    twin = m["settling"]["noise_free_twin"]
    assert twin["settled"] and not twin["limit_cycle"] and twin["block_change"] < 0.01


@pytest.mark.parametrize("hz,amp,decay,expected", [(3.1, 5.0, 0.0, "limit_cycle"), (3.1, 0.5, 0.0, "settled"),
                                                     (2.0, 5.0, 0.0, "settled"), (3.1, 5.0, 0.15, "unsettled")])
def test_limit_cycle_is_named_with_its_frequency_and_amplitude(hz, amp, decay, expected):
    # Error = a part periodic with the 1 Hz reference (0.3 N + 0.5 N sin 2 pi t) plus a sine of
    # frequency hz and amplitude amp decaying as exp(-decay t): a steady 3.1 Hz, 5 N oscillation is
    # a limit cycle reported as 3.1 Hz, 5 N (within 1 % / 2 %: the fit on 10 s of 1 kHz samples);
    # 0.5 N is below 5 % of the 24 N reference; 2 Hz is a reference harmonic (the periodic error
    # of a settled run); the decaying one (amplitude halves in 4.6 s) is neither settled nor a
    # limit cycle.
    from sensor.pneumatic.controllers import Reference
    ref = Reference("sine", 1.0, 24.0)
    ds = _synthetic_run(lambda t: 0.3 + 0.5 * np.sin(2 * np.pi * t) + amp * np.exp(-decay * t) * np.sin(2 * np.pi * hz * t))
    m = metrics(ds, ref)
    assert m["status"] == expected
    assert m["limit_cycle"] is (expected == "limit_cycle") and m["settled"] is (expected == "settled")
    if expected == "limit_cycle":
        assert m["limit_cycle_hz"] == pytest.approx(hz, rel=0.01)
        assert m["limit_cycle_amplitude_N"] == pytest.approx(amp, rel=0.02)
    else:
        assert "limit_cycle_hz" not in m


def test_plant_and_estimators_start_from_the_atmosphere():
    # One physical start (DESIGN section 15): every chamber and line node at the atmosphere,
    # the observer's and the line model's estimates too (not 0 Pa), zero force at rest.
    s = Setup(controller="line-model", observer="force", reference="sine:1Hz", line_length_m=2.0, segments=4,
              valve="enfield-lh05", duration_s=0.01)
    ds = run(s)
    atm = build_plant(s).air.atmosphere_Pa
    first = ds.isel(time=0)
    pressures = [v for v in first.states.values[2:] if v > 1e3]        # every pressure node of both lines
    assert len(pressures) == 10 and np.all(np.array(pressures) == atm)
    assert float(first.estimated_pressure_1_Pa) == atm and float(first.estimated_pressure_2_Pa) == atm
    # the line model starts from the (noisy) valve-port readings: within the transducers' noise
    assert abs(float(first.line_model_pressure_1_Pa) - atm) < 1e3
    assert abs(float(first.environment_force)) < 1e-9


@pytest.mark.parametrize("substep_s", [None, 5e-5, "default"])
def test_setup_substep_reaches_the_plant(substep_s):
    # default: LOOP_SUBSTEP_S; None: the plant's automatic substep (0.25 ms cap with a
    # distributed line, 0.2 ms here); a value is used as given
    kw = {} if substep_s == "default" else {"substep_s": substep_s}
    s = Setup(controller="pi", line_length_m=2.0, segments=4, duration_s=0.01, **kw)
    h = run(s).attrs["substep_s"]
    automatic = build_plant(s).compile().substeps(1e-3)[1]
    assert automatic > 1.5e-4
    assert h == pytest.approx({None: automatic, 5e-5: 5e-5, "default": LOOP_SUBSTEP_S}[substep_s], rel=1e-12)


@pytest.mark.parametrize("bad", [0.0, -1e-4, float("nan"), float("inf")])
def test_setup_refuses_a_bad_substep(bad):
    with pytest.raises(SensorInputError, match="substep_s"):
        Setup(substep_s=bad)


def test_controller_study_rows_carry_the_thesis_and_our_line_model_apart():
    from sensor.pneumatic.studies import controller_study
    from sensor.pneumatic.tuning import tune
    tuned = {5.0: tune(5.0, segments=4)}
    res = controller_study(duration_s=3.0, segments=4, lengths=(5.0,), references=("sine:2Hz",), tuned=tuned)
    (row,) = res["rows"]
    assert set(row) == {"line_length_m", "reference", "smc", "line_model_thesis", "smc_rule", "line_model_thesis_rule",
                        "line_model_damped", "thesis_table4", "status", "settled", "limit_cycle"}
    for key in ("smc", "line_model_thesis"):     # the primary rows run the tuned gains
        side = "smc" if key == "smc" else "line_model"
        assert row[key]["gains"] == pytest.approx(tuned[5.0][side]["gains"])
    for key in ("smc", "line_model_thesis", "line_model_damped"):
        assert isinstance(row[key]["settled"], bool) and isinstance(row[key]["limit_cycle"], bool)
        assert ("limit_cycle_hz" in row[key]) is row[key]["limit_cycle"]
    assert row["thesis_table4"] == {"mse1_N2": 6.44, "mse2_N2": 8.22}
    assert row["smc"]["mse2_N2"] is None and row["line_model_thesis"]["mse2_N2"] > 0
    assert row["line_model_thesis"]["gains"]["flow_rate_per_s"] == 0.0
    assert row["line_model_damped"]["gains"]["flow_rate_per_s"] > 0
    assert row["settled"] == all(row[k]["settled"] for k in ("smc", "line_model_thesis", "smc_rule",
                                                              "line_model_thesis_rule", "line_model_damped"))
