"""Readout noise: analytic budget against simulated samples, source-drift cancellation."""

import math

import numpy as np
import pytest
from scipy.constants import e as Q_E

from sensor.errors import OpticsError
from sensor.readout.noise import READOUTS, noise_budget, noise_rms_V, sample_output
from sensor.readout.optics import OpticsSetup, output_voltage

SETUP = OpticsSetup()
# A noisier source (-100 dB/Hz) makes the source term dominate the direct readout.
NOISY = OpticsSetup(source_rin_dB_per_Hz=-100.0)
N = 20_000  # the sample std has a relative standard error 1/sqrt(2N) = 0.5 %


@pytest.mark.parametrize("setup", [SETUP, NOISY])
@pytest.mark.parametrize("readout", READOUTS)
@pytest.mark.parametrize("gap", [0.0, 0.4, 1.2])
def test_sampled_rms_matches_analytic_noise(setup, readout, gap):
    rate = 2000.0
    rng = np.random.default_rng(11)
    samples = sample_output(np.full(N, gap), setup, rate, rng, readout=readout)
    predicted = float(noise_rms_V(setup, rate / 2, gap, readout=readout))
    assert samples.std() == pytest.approx(predicted, rel=0.05)  # 10 standard errors
    # Zero-mean noise: the mean reads the noise-free curve within 5 standard errors.
    assert abs(samples.mean() - output_voltage(gap, setup)) < 5 * predicted / math.sqrt(N)


def test_shot_noise_term_matches_poisson_photoelectron_counting():
    # Independent of the 2 q I B formula: count Poisson photoelectrons over the sample
    # interval 1/(2B) and convert back to current, then to volts through the gain.
    band, gap = 1000.0, 0.5
    shot = float(noise_budget(SETUP, band, gap).shot_V)
    current = float(output_voltage(gap, SETUP) - SETUP.offset_V) / SETUP.gain_V_per_A
    tau = 1.0 / (2.0 * band)
    counts = np.random.default_rng(3).poisson(current * tau / Q_E, N)
    assert SETUP.gain_V_per_A * np.std(counts * Q_E / tau) == pytest.approx(shot, rel=0.05)


def test_noise_scales_with_square_root_of_bandwidth():
    a, b = (noise_rms_V(NOISY, band, 0.5, readout="direct") for band in (100.0, 400.0))
    assert b == pytest.approx(2 * a, rel=1e-12)


def test_reference_ratio_removes_source_drift():
    # The source power sags by 20 % over the record (a laser warming up).
    gap, rate = 0.6, 1000.0
    drift = np.linspace(1.0, 0.8, N)
    nominal = float(output_voltage(gap, SETUP))
    signal = nominal - SETUP.offset_V
    t = np.arange(N)
    out = {ro: sample_output(np.full(N, gap), SETUP, rate, np.random.default_rng(5),
                             readout=ro, source_scale=drift) for ro in READOUTS}
    b = noise_budget(SETUP, rate / 2, gap, readout="ratio")
    sigma = float(b.total_V)
    # Direct readout follows the drift: a 20 % fall of the signal over the record.
    trend_direct = np.polyfit(t, out["direct"], 1)[0] * (N - 1)
    assert trend_direct == pytest.approx(-0.2 * signal, rel=0.01)
    # Ratio readout: no trend beyond 5 standard errors of a fitted slope.
    trend_ratio = np.polyfit(t, out["ratio"], 1)[0] * (N - 1)
    trend_se = sigma * math.sqrt(12.0 / N)  # std error of the end-to-end change of a fit
    assert abs(trend_ratio) < 5 * trend_se
    # Its scatter is the analytic noise at the dimmer source: rescaled by 1/s, shot noise
    # grows as s^-1/2 and Johnson noise as s^-1.
    var = np.mean((b.shot_V**2 + b.reference_V**2) / drift + b.johnson_V**2 / drift**2)
    assert out["ratio"].std() == pytest.approx(math.sqrt(var), rel=0.05)


def test_ratio_readout_is_quieter_than_direct_when_source_noise_dominates():
    budget = noise_budget(NOISY, 500.0, 0.5, readout="direct")
    assert budget.source_V > 10 * max(budget.shot_V, budget.johnson_V)
    assert noise_rms_V(NOISY, 500.0, 0.5, readout="ratio") < 0.1 * budget.total_V


@pytest.mark.parametrize("call, name", [
    (lambda: noise_rms_V(SETUP, 0.0, 0.5), "bandwidth_Hz"),
    (lambda: noise_rms_V(SETUP, 100.0, -0.5), "gap_mm"),
    (lambda: noise_rms_V(SETUP, 100.0, 0.5, readout="lockin"), "readout"),
    (lambda: sample_output([0.5], SETUP, -10.0, np.random.default_rng()), "sample_rate_Hz"),
    (lambda: sample_output([0.5], SETUP, 10.0, 42), "rng"),
    (lambda: sample_output([0.5, 0.6], SETUP, 10.0, np.random.default_rng(),
                           source_scale=[1.0, 0.0]), "source_scale"),
])
def test_bad_arguments_are_rejected(call, name):
    with pytest.raises(OpticsError, match=name):
        call()
