"""Fiber-mirror intensity models: limits, an independent ray trace, linearity definitions."""

import math

import numpy as np
import pytest

from sensor.errors import OpticsError, SensorError
from sensor.readout.optics import (
    LINES,
    MODELS,
    OpticsSetup,
    _line_deviation,
    collected_power,
    collection_efficiency,
    linearity,
    output_voltage,
    voltage_slope,
    working_range,
)

SETUP = OpticsSetup()


def test_zero_gap_is_full_core_overlap_times_reflectivity_plus_back_reflection():
    # At d = 0 the image fiber coincides with the fiber: the overlap is the whole core (1)
    # for the geometric model, and 1 - exp(-2) for a Gaussian of waist = core radius.
    rf, rm, launched = SETUP.end_face_reflectance, SETUP.mirror_reflectivity, SETUP.launched_power_W
    for model, overlap in (("geometric", 1.0), ("gaussian", 1.0 - math.exp(-2.0))):
        assert collection_efficiency(0.0, SETUP, model) == pytest.approx(overlap, abs=1e-12)
        expected = launched * (rf + (1 - rf) ** 2 * rm * overlap)
        assert collected_power(0.0, SETUP, model) == pytest.approx(expected, rel=1e-12)


@pytest.mark.parametrize("model", MODELS)
def test_far_field_falls_as_inverse_square(model):
    # The corrections to the 1/d^2 law are O((a/d)^2) = 0.2 % at d = 10 mm: the local
    # log-log slope must be -2 within 0.005, and eta must approach a^2 / (4 NA^2 d^2).
    d = np.array([10.0, 10.01])
    eta = collection_efficiency(d, SETUP, model)
    slope = np.log(eta[1] / eta[0]) / np.log(d[1] / d[0])
    assert slope == pytest.approx(-2.0, abs=0.005)
    asymptote = SETUP.core_radius_mm**2 / (4 * SETUP.numerical_aperture**2 * d[0] ** 2)
    assert eta[0] == pytest.approx(asymptote, rel=0.005)


@pytest.mark.parametrize("model", MODELS)
@pytest.mark.parametrize("setup", [SETUP, OpticsSetup(mirror_reflectivity=1.0,
                                                      end_face_reflectance=0.0,
                                                      numerical_aperture=0.9)])
def test_collected_never_exceeds_emitted_times_reflectivity(model, setup):
    gaps = np.linspace(0.0, 5.0, 501)
    eta = collection_efficiency(gaps, setup, model)
    assert np.all((eta >= 0) & (eta <= 1))
    assert np.all(np.diff(eta) < 0)  # a single fiber's curve falls monotonically
    back = setup.launched_power_W * setup.end_face_reflectance
    mirror_part = collected_power(gaps, setup, model) - back
    assert np.all(mirror_part <= setup.emitted_power_W * setup.mirror_reflectivity * (1 + 1e-12))


def test_geometric_and_gaussian_agree_in_far_field_not_near():
    # Both models are matched to the same on-axis far-field intensity; their difference is
    # O((a/d)^2): within 1 % at 5 mm (measured 0.4 %), and shrinking about 4x per doubling.
    far = np.array([5.0, 10.0])
    geo, gau = (collection_efficiency(far, SETUP, m) for m in MODELS)
    rel = np.abs(gau - geo) / geo
    assert rel[0] < 0.01
    assert rel[1] == pytest.approx(rel[0] / 4, rel=0.1)
    # ... whereas near the fiber they are different models (13.5 % apart at zero gap).
    assert collection_efficiency(0.0, SETUP, "gaussian") < 0.9


def _ray_trace_eta(gap_mm, setup, n_rays, rng):
    """Monte Carlo: points uniform on the core, Lambertian directions within the NA."""
    a, na = setup.core_radius_mm, setup.numerical_aperture
    r0 = a * np.sqrt(rng.random(n_rays))
    phi0 = 2 * np.pi * rng.random(n_rays)
    sin_t = na * np.sqrt(rng.random(n_rays))  # Lambertian: sin^2(theta) uniform
    psi = 2 * np.pi * rng.random(n_rays)
    reach = 2 * gap_mm * sin_t / np.sqrt(1 - sin_t**2)  # mirror image: path 2d
    x = r0 * np.cos(phi0) + reach * np.cos(psi)
    y = r0 * np.sin(phi0) + reach * np.sin(psi)
    return np.mean(x**2 + y**2 <= a**2)


@pytest.mark.parametrize("na", [0.5, 0.2])
def test_geometric_model_matches_independent_ray_trace(na):
    setup = OpticsSetup(numerical_aperture=na)
    rng = np.random.default_rng(7)
    n = 400_000
    for gap in (0.1, 0.4, 1.0, 2.5):
        mc = _ray_trace_eta(gap, setup, n, rng)
        eta = float(collection_efficiency(gap, setup, "geometric"))
        sigma = math.sqrt(eta * (1 - eta) / n)  # binomial standard error
        assert abs(mc - eta) < 5 * sigma, (gap, mc, eta)


@pytest.mark.parametrize("na", [0.5, 0.2, 0.9])
def test_geometric_rule_matches_adaptive_quadrature(na):
    """The fixed 32-point rule against scipy's adaptive quad of eta = int_0^1 c(x(u)) du in
    the original variable u (told where x(u) reaches one core diameter, found by brentq) and
    of its gap derivative, from zero gap through the onset of that cut-off (the edge just
    beyond u = 1 is the hardest case) to 3 mm: 1e-10 relative (measured 2e-12)."""
    from scipy.integrate import quad
    from scipy.optimize import brentq

    setup = OpticsSetup(numerical_aperture=na)
    two_a = setup.core_diameter_mm
    onset = two_a / (2 * math.tan(math.asin(na)))
    gaps = np.concatenate([[0.0, 1e-6], onset * (1 + np.array([-1e-4, -1e-6, 0.0, 1e-6])),
                           np.linspace(0.01, 3.0, 23)])
    # V' = G S (1 - k) P_launch (1 - R_f)^2 R_m d(eta)/d(gap)
    gain = (setup.gain_V_per_A * setup.responsivity_A_per_W * (1 - setup.coupler_ratio)
            * setup.launched_power_W * (1 - setup.end_face_reflectance) ** 2 * setup.mirror_reflectivity)
    for gap in gaps:
        def x(u, gap=gap):
            return 2 * gap * math.tan(math.asin(na * math.sqrt(u))) / two_a

        def c(u):
            xu = min(x(u), 1.0)
            return (2 / math.pi) * (math.acos(xu) - xu * math.sqrt(1 - xu * xu))

        def dc(u):
            return -(8 / math.pi) * math.tan(math.asin(na * math.sqrt(u))) / two_a * math.sqrt(max(0.0, 1 - x(u) ** 2))

        edge = [brentq(lambda u: x(u) - 1, 0, 1, xtol=1e-15)] if x(1.0) > 1 else None
        eta = quad(c, 0, 1, points=edge, epsabs=1e-15, epsrel=1e-13, limit=400)[0]
        deta = quad(dc, 0, 1, points=edge, epsabs=1e-15, epsrel=1e-13, limit=400)[0]
        assert collection_efficiency(gap, setup, "geometric") == pytest.approx(eta, rel=1e-10, abs=1e-15), gap
        assert voltage_slope(gap, setup, "geometric") / gain == pytest.approx(deta, rel=1e-10, abs=1e-12), gap


@pytest.mark.parametrize("model", MODELS)
def test_voltage_slope_matches_finite_difference(model):
    gaps = np.array([0.0, 0.3, 0.7, 1.2, 3.0])
    h = 1e-5
    fd = (output_voltage(gaps + 2 * h, SETUP, model) - output_voltage(gaps, SETUP, model)) / (2 * h)
    slope = voltage_slope(gaps + h, SETUP, model)
    np.testing.assert_allclose(slope, fd, rtol=1e-6, atol=1e-9)
    assert np.all(voltage_slope(gaps[1:], SETUP, model) < 0)


def test_line_deviation_of_a_parabola_is_exact():
    # f = x^2 on [0, 1]: least-squares line x - 1/6 deviates 1/6 at the ends (16.67 % FS);
    # the chord x deviates 1/4 at x = 1/2 (25 % FS). The grid mean-fit converges as 1/n^2.
    x = np.linspace(0, 1, 2001)
    best, slope, intercept = _line_deviation(x**2, x, "best_fit")
    assert best == pytest.approx(100 / 6, rel=1e-3)
    assert (slope, intercept) == (pytest.approx(1.0, rel=1e-3), pytest.approx(-1 / 6, rel=1e-3))
    assert _line_deviation(x**2, x, "endpoint")[0] == pytest.approx(25.0, rel=1e-6)


@pytest.mark.parametrize("model", MODELS)
def test_nonlinearity_is_independent_of_gains_power_and_reflectivity(model):
    # V = offset + const * (R_f + (1-R_f)^2 R_m eta): % FS depends on eta's shape alone.
    other = OpticsSetup(source_power_W=1e-3, mirror_reflectivity=0.9, gain_V_per_A=3e4,
                        offset_V=-1.0, end_face_reflectance=0.1, responsivity_A_per_W=0.3)
    a, b = (linearity(0.2, 1.2, s, model).nonlinearity_pct for s in (SETUP, other))
    assert a == pytest.approx(b, rel=1e-9)


@pytest.mark.parametrize("model", MODELS)
@pytest.mark.parametrize("line", LINES)
def test_working_range_is_within_tolerance_and_locally_widest(model, line):
    tol, step = 1.0, 0.01
    wr = working_range(SETUP, tol, model, line, gap_max_mm=2.0, step_mm=step)
    assert wr.nonlinearity_pct <= tol and wr.width_mm > 0.2
    # A 10x finer evaluation of the same interval agrees to grid resolution: the grid can
    # miss an interior extremum of the deviation by O(step^2) (measured <= 0.011 % FS).
    fine = linearity(wr.gap_lo_mm, wr.gap_hi_mm, SETUP, model, line, step_mm=step / 10)
    assert fine.nonlinearity_pct <= tol + 0.02
    assert fine.slope_V_per_mm == pytest.approx(wr.slope_V_per_mm, rel=1e-3)
    # Growing the interval by one step at either end breaks the tolerance.
    for lo, hi in ((wr.gap_lo_mm - step, wr.gap_hi_mm), (wr.gap_lo_mm, wr.gap_hi_mm + step)):
        if lo >= 0:
            assert linearity(lo, hi, SETUP, model, line, step_mm=step).nonlinearity_pct > tol


def test_working_range_slope_is_the_mean_curve_slope():
    # The least-squares slope of a smooth curve is close to the chord slope (V(b)-V(a))/(b-a).
    wr = working_range(SETUP, 1.0, "geometric", step_mm=0.01)
    v = output_voltage([wr.gap_lo_mm, wr.gap_hi_mm], SETUP)
    assert wr.slope_V_per_mm == pytest.approx((v[1] - v[0]) / wr.width_mm, rel=0.02)


@pytest.mark.parametrize("kwargs, name", [
    ({"numerical_aperture": 0.0}, "numerical_aperture"),
    ({"numerical_aperture": 1.0}, "numerical_aperture"),
    ({"numerical_aperture": 1.3}, "numerical_aperture"),
    ({"source_power_W": -5e-3}, "source_power_W"),
    ({"core_diameter_mm": 0.0}, "core_diameter_mm"),
    ({"mirror_reflectivity": 1.2}, "mirror_reflectivity"),
    ({"end_face_reflectance": 1.0}, "end_face_reflectance"),
    ({"coupler_ratio": 1.0}, "coupler_ratio"),
    ({"gain_V_per_A": float("nan")}, "gain_V_per_A"),
    ({"temperature_K": -1.0}, "temperature_K"),
])
def test_bad_setup_is_rejected_with_a_clear_message(kwargs, name):
    with pytest.raises(OpticsError) as err:
        OpticsSetup(**kwargs)
    msg = str(err.value)
    assert isinstance(err.value, SensorError) and name in msg and "must be" in msg
    assert str(next(iter(kwargs.values()))) in msg


@pytest.mark.parametrize("call, name", [
    (lambda: collected_power(-0.1, SETUP), "gap_mm"),
    (lambda: output_voltage([0.1, float("nan")], SETUP), "gap_mm"),
    (lambda: collected_power(0.5, SETUP, model="ray"), "model"),
    (lambda: working_range(SETUP, 0.0), "tolerance_pct"),
    (lambda: working_range(SETUP, 1.0, line="minimax"), "line"),
    (lambda: working_range(SETUP, 1.0, gap_min_mm=2.0, gap_max_mm=1.0), "gap_max_mm"),
    (lambda: linearity(0.5, 0.5, SETUP), "gap_hi_mm"),
    (lambda: linearity(0.1, 0.5, SETUP, step_mm=-1.0), "step_mm"),
    (lambda: working_range(SETUP, 1e-9, step_mm=0.01), "tolerance_pct"),
])
def test_bad_arguments_are_rejected(call, name):
    with pytest.raises(OpticsError, match=name):
        call()
